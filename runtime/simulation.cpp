#include "runtime/simulation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>

#include "kernels/contact_detection.hpp"
#include "kernels/initial_state.hpp"
#include "kernels/integrator.hpp"
#include "kernels/isotropic_start.hpp"
#include "kernels/order_tensor.hpp"
#include "kernels/thermostat.hpp"
#include "runtime/body_wire.hpp"
#include "runtime/checkpoint.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

namespace {

// Global axis moments from the first six of a rank-summed list (xx, xy, xz, yy, yz, zz).
AxisMoments moments_from(const std::vector<ExactSum> &sums, long long n) {
  AxisMoments m;
  m.xx = sums[0];
  m.xy = sums[1];
  m.xz = sums[2];
  m.yy = sums[3];
  m.yz = sums[4];
  m.zz = sums[5];
  m.count = n;
  return m;
}

std::size_t partner_slot(const std::vector<int> &partners, int rank) {
  return static_cast<std::size_t>(std::lower_bound(partners.begin(), partners.end(), rank) -
                                  partners.begin());
}

}  // namespace

// The scene's initial bodies, the same on every rank: on the lattice, compressed from a
// random isotropic state (every rank computes the same, deterministic in the seed), or
// positions and axes from an H5MD frame (n and box must match the scene); fresh velocities.
Particles initial_bodies(const Scene &scene) {
  Particles all;
  if (scene.configuration == Configuration::kFile) {
    const std::string key = fmt::format("init.file = \"{}\"", scene.init_file);
    SnapshotFrame f;
    try {
      f = read_h5md_frame(scene.init_file, scene.init_frame);
    } catch (const std::runtime_error &e) {
      throw SceneError({fmt::format("{}: {}", key, e.what())});
    }
    if (static_cast<long long>(f.bodies.size()) != scene.n)
      throw SceneError({fmt::format("{}: frame {} holds {} bodies, system.n = {}", key, f.frame,
                                    f.bodies.size(), scene.n)});
    const Vec3 &a = f.box.length, &b = scene.box.length;
    for (double r : {a.x / b.x, a.y / b.y, a.z / b.z})
      if (std::fabs(r - 1.0) > 1e-12)
        throw SceneError({fmt::format(
            "{}: box {} x {} x {}, the scene's is {} x {} x {} (system.box or the density)", key,
            a.x, a.y, a.z, b.x, b.y, b.z)});
    all = std::move(f.bodies);
  } else if (scene.configuration == Configuration::kIsotropic) {
    try {
      all = make_isotropic(scene.n, scene.shape, scene.box, scene.seed);
    } catch (const std::exception &e) {
      throw SceneError({fmt::format("init.configuration = \"isotropic\": {}", e.what())});
    }
  } else {
    place_on_lattice(all, scene.box, scene.lattice, scene.axis);
  }
  assign_velocities(all, scene.shape, scene.seed, scene.temperature);
  return all;
}

Simulation::Simulation(Scene scene, ParallelOptions parallel) : scene_(std::move(scene)) {
  configure(initial_bodies(scene_), parallel);
}

Simulation::Simulation(Scene scene, Particles bodies, ParallelOptions parallel,
                       long long first_step)
    : scene_(std::move(scene)), step_(first_step) {
  if (static_cast<long long>(bodies.size()) != scene_.n)
    throw std::invalid_argument(
        fmt::format("Simulation: {} bodies given for a scene of n = {}", bodies.size(), scene_.n));
  configure(std::move(bodies), parallel);
}

void Simulation::configure(Particles all, ParallelOptions parallel) {
  kinetic_target_ = hardrod::target_kinetic_energy(scene_.n, scene_.shape, scene_.temperature);
  list_.skin = scene_.skin;
  solver_.tolerance = scene_.solver_tolerance;
  solver_.max_iterations = static_cast<int>(scene_.solver_max_iterations);

  balance_ = parallel.balance;
  results_exchange_ = parallel.results_exchange;
  if (balance_.interval < 1)
    throw SceneError(
        {fmt::format("--balance-interval must be at least 1, got {}", balance_.interval)});
  std::array<int, 3> grid = parallel.grid;
  if (grid[0] * grid[1] * grid[2] == 0) {
    grid = comm_.make_grid({0, 0, 0});  // non-increasing counts
    // Rods aligned along an axis need shadows half a rod further along it than across:
    // give the fewest cuts to the axis the bodies are most aligned with.
    const OrderParameter q = order_parameter(axis_moments(all, all.size()));
    std::array<int, 3> axes{0, 1, 2};
    const double d[3] = {std::fabs(q.director.x), std::fabs(q.director.y), std::fabs(q.director.z)};
    if (!scene_.shape.is_sphere() && std::isfinite(q.S))
      std::stable_sort(axes.begin(), axes.end(), [&](int a, int b) { return d[a] < d[b]; });
    const std::array<int, 3> counts = grid;
    for (int k = 0; k < 3; ++k) grid[axes[k]] = counts[k];
  }
  if (grid[0] * grid[1] * grid[2] != comm_.size())
    throw SceneError({fmt::format("--grid {}x{}x{}: needs {} ranks, running on {}", grid[0],
                                  grid[1], grid[2], grid[0] * grid[1] * grid[2], comm_.size())});
  // A body is shadowed where its axis segment comes within L/2 + D + skin of a subdomain:
  // every point of an owned body's segment stays within L/2 + skin/2 of the subdomain until
  // the next rebuild, and every point of another body moves at most skin/2, so every body
  // that can touch an owned body is held. Partners: any two ranks that can hold one body.
  const Shape &shape = scene_.shape;
  const double shadow_reach = shape.half_length() + shape.diameter + scene_.skin;
  const double partner_reach = 2.0 * (shadow_reach + shape.half_length());
  domain_ = Domain(scene_.box, grid, comm_.rank(), shadow_reach, partner_reach);
  if (balance_.mode != BalanceMode::kOff && comm_.size() > 1) {
    // Every rank holds all bodies here: start from cuts that share them out evenly along
    // each axis (a few passes of the balancer on the slabs' counts; the same on every rank).
    Cuts cuts = domain_.cuts();
    const double *at[3] = {all.x.data(), all.y.data(), all.z.data()};
    const double sides[3] = {scene_.box.length.x, scene_.box.length.y, scene_.box.length.z};
    for (int pass = 0; pass < 4; ++pass)
      for (int a = 0; a < 3; ++a) {
        if (grid[a] < 2) continue;
        std::vector<double> counts(static_cast<std::size_t>(grid[a]), 0.0);
        for (std::size_t i = 0; i < all.size(); ++i)
          counts[static_cast<std::size_t>(Domain::slab(cuts[a], Box::wrap(at[a][i], sides[a])))] +=
              1.0;
        cuts[a] = balanced_cuts(cuts[a], counts, 0.5 * sides[a] / grid[a], sides[a]);
      }
    domain_ = Domain(scene_.box, grid, comm_.rank(), shadow_reach, partner_reach, cuts);
  }

  // Every rank makes the same full state and keeps the bodies whose centres it owns.
  Particles mine;
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (domain_.owner_of(all.position(i)) != comm_.rank()) continue;
    const std::size_t k = mine.size();
    mine.resize(k + 1);
    mine.id[k] = all.id[i];
    for (auto [dst, src] : {std::pair{&mine.x, &all.x},
                            {&mine.y, &all.y},
                            {&mine.z, &all.z},
                            {&mine.ex, &all.ex},
                            {&mine.ey, &all.ey},
                            {&mine.ez, &all.ez},
                            {&mine.vx, &all.vx},
                            {&mine.vy, &all.vy},
                            {&mine.vz, &all.vz},
                            {&mine.wx, &all.wx},
                            {&mine.wy, &all.wy},
                            {&mine.wz, &all.wz}})
      (*dst)[k] = (*src)[i];
  }
  particles_ = std::move(mine);
  owned_ = particles_.size();
}

void Simulation::fail(const std::string &message) { throw PhysicsError(message); }

void Simulation::step() { advance(1); }

// Steps in a row: between two steps of one call nothing reads the state, so the second half
// of a step and the first half of the next run as one pass over the bodies (to_midpoint(2):
// the same bits as two passes), except where the rotor constraints or the thermostat act
// between them, or a stop was agreed.
void Simulation::advance(long long count) {
  const double half_dt = 0.5 * scene_.dt;
  const Shape &shape = scene_.shape;
  MidpointDetection reached;
  bool at_midpoint = false;  // the first half of this step is done already
  // The drift reads each body's motion constants: current from here on, whatever changed the
  // velocities since the last call. Within the call they follow every change: impulses and
  // rebuilds (midpoint), the rotor constraints and the thermostat (below).
  {
    ScopedRegion r(timers_, Region::kIntegrate);
    refresh_motion(particles_, advanced(), shape, half_dt);
  }
  for (long long k = 0; k < count; ++k) {
    // 1. first half: free flight to the midpoint, owned bodies and shadows (and, in the same
    // parallel region, the detection there)
    if (!at_midpoint) reached = to_midpoint(1);
    midpoint(reached);  // 2.-3. contacts and impulses
    ++step_;
    const bool constrain = step_ % kConstraintInterval == 0;
    const bool thermostat =
        scene_.thermostat_interval > 0 && step_ % scene_.thermostat_interval == 0;
    at_midpoint = k + 1 < count && !constrain && !thermostat && !stop_agreed_;
    // 4. second half, and with it the next step's first half where nothing acts between
    if (at_midpoint) {
      reached = to_midpoint(2);
    } else {
      // half_step refreshes every body's motion constants itself: a step() at a time so
      // does not depend on the refreshes within a burst, and the tests compare the two
      // (one refresh of all bodies per burst, ~2 ns per body).
      ScopedRegion r(timers_, Region::kIntegrate);
      half_step(particles_, advanced(), shape, half_dt);
    }
    if (constrain) {
      ScopedRegion r(timers_, Region::kIntegrate);
      restore_rotor_constraints(particles_, advanced());
      refresh_motion(particles_, advanced(), shape, half_dt);
    }
    if (thermostat) {
      ScopedRegion r(timers_, Region::kThermostat);
      apply_thermostat();
      refresh_motion(particles_, advanced(), shape, half_dt);
    }
    if (stop_agreed_) return;
    if (balance_.mode != BalanceMode::kOff && comm_.size() > 1 && step_ % balance_.interval == 0)
      check_balance();
  }
}

// Free flight to the midpoint (`halves` half steps) and the detection there when the list
// keeps its watches: one parallel region (advance_to_midpoint). Timed as integrate and
// detect.
MidpointDetection Simulation::to_midpoint(int halves) {
  const auto start = std::chrono::steady_clock::now();
  MidpointDetection m = advance_to_midpoint(particles_, advanced(), scene_.shape, 0.5 * scene_.dt,
                                            halves, list_, scene_.box, contacts_);
  const long long all =
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - start)
          .count();
  timers_.add(Region::kIntegrate, m.drift_nanoseconds);
  if (m.detected) {
    timers_.add(Region::kDetect, all - m.drift_nanoseconds);
    note_detection(m.stats);
  }
  return m;
}

// The middle of a step, with the bodies at its midpoint: contacts, the step's agreement, a
// rebuild if the list expired, impulses, and the step's tallies.
void Simulation::midpoint(const MidpointDetection &reached) {
  const Shape &shape = scene_.shape;
  const double largest_bound = reached.largest_bound;
  // 2. contacts at the midpoint, found before the step's one reduction so that it can also
  // tell every rank whether any contact touches a rank boundary this step. A rank whose own
  // bounds already expire the list skips this: it knows a rebuild follows.
  DetectionStats detected;
  bool boundary = false;
  const bool expired_here = neighbor_list_expired(list_, largest_bound, particles_.size());
  if (!expired_here) {
    detected = reached.detected ? reached.stats : detect();
    boundary = touches_boundary();
  }
  Agreement agreed = agree(largest_bound, boundary);
  if (force_rebuild_) {  // new cuts (check_balance; the same decision on every rank)
    agreed.rebuild = true;
    force_rebuild_ = false;
    ++balanced_.forced_rebuilds;
  }
  if (agreed.rebuild) {
    rebuild();
    detected = detect();  // a problem is reported at the next step's agreement
    if (comm_.size() == 1) report_pending_problems();
  }
  // Contacts' results travel between ranks only when some rank has a contact that involves a
  // shadow or a body that other ranks hold (agreed above), or the shadows were just renewed.
  const bool exchange = comm_.size() > 1 && (agreed.boundary || agreed.rebuild);

  ResolutionStats resolved;
  std::vector<char> counted(contacts_.size(), 1);
  // 3. elastic impulses (nothing to do in most steps at small dt: no contact here, and no
  // exchange, which all ranks must join)
  if (!contacts_.empty() || exchange) {
    ScopedRegion r(timers_, Region::kResolve);
    const ContactClusters clusters = find_clusters(contacts_);
    if (comm_.size() == 1) {
      resolved = resolve_clusters(particles_, shape, contacts_, clusters, {}, solver_);
    } else {
      // Without an exchange every cluster is made of bodies only this rank holds: resolved
      // here. With one, the clusters with a body other ranks hold are put together across
      // ranks (resolve_across_ranks).
      std::vector<char> local(clusters.count(), 1);
      if (exchange)
        for (std::size_t c = 0; c < clusters.count(); ++c)
          for (std::size_t k = clusters.start[c]; k < clusters.start[c + 1] && local[c]; ++k) {
            const Contact &ct = contacts_[clusters.order[k]];
            local[c] = !shared_[ct.i] && !shared_[ct.j];
          }
      resolved = resolve_clusters(particles_, shape, contacts_, clusters, local, solver_, owned_);
      if (exchange) {
        const ResolutionStats across = resolve_across_ranks(clusters, local);
        resolved.clusters += across.clusters;
        resolved.iterations_max = std::max(resolved.iterations_max, across.iterations_max);
        resolved.unconverged += across.unconverged;
        interval_.solver_energy_change.add(across.energy_change);
      }
      // Each contact is counted once in the whole system: by the owner of its lower id.
      for (std::size_t k = 0; k < contacts_.size(); ++k) counted[k] = contacts_[k].i < owned_;
    }
    if (!agreed.rebuild) {  // the bodies of the impulses, here and from other ranks
      changed_.clear();
      for (const Contact &c : contacts_) {
        changed_.push_back(c.i);
        changed_.push_back(c.j);
      }
      changed_.insert(changed_.end(), shared_in_.begin(), shared_in_.end());
      refresh_motion(particles_, changed_, shape, 0.5 * scene_.dt);
    }
    shared_in_.clear();
    if (comm_.size() == 1) {
      interval_.multi_contact_bodies += clusters.multi_contact_bodies;
    } else {  // owned bodies only: their contacts are all seen here, each counted once
      for (std::size_t b = 0; b < clusters.bodies.size(); ++b)
        interval_.multi_contact_bodies += clusters.bodies[b] < owned_ && clusters.degree[b] > 1;
    }
  }
  // Velocities that changed: the motion constants follow (all after a rebuild, which
  // brings bodies and renews the shadows; else the impulses' bodies, in resolve above).
  if (agreed.rebuild) {
    ScopedRegion r(timers_, Region::kIntegrate);
    refresh_motion(particles_, advanced(), shape, 0.5 * scene_.dt);
  }
  const CollisionTally tally = tally_collisions(contacts_, counted);
  interval_.steps += 1;
  interval_.collisions += tally.collisions;
  interval_.virial += tally.virial;
  interval_.narrow_phase_tests += detected.narrow_phase_tests;
  for (std::size_t k = 0; k < contacts_.size(); ++k) interval_.contacts += counted[k];
  interval_.clusters += resolved.clusters;
  interval_.solver_iterations_max =
      std::max(interval_.solver_iterations_max, resolved.iterations_max);
  interval_.solver_unconverged += resolved.unconverged;
  interval_.max_depth = std::max(interval_.max_depth, detected.max_depth);
  interval_.solver_energy_change.add(resolved.energy_change);
}

// One max-reduction per step: whether any rank's pair list expired, whether any rank has a
// contact across a rank boundary, any problem a rank saw (so that every rank stops together)
// and a stop asked for by a signal.
Simulation::Agreement Simulation::agree(double largest_bound, bool boundary) {
  std::vector<double> flags{largest_bound,
                            pending_depth_,
                            pending_unresolved_,
                            static_cast<double>(pending_step_),
                            stop_requested_ ? 1.0 : 0.0,
                            boundary ? 1.0 : 0.0};
  if (comm_.size() > 1) {
    ScopedRegion r(timers_, Region::kAgree);
    flags = comm_.max("agree", flags);
  }
  stop_agreed_ = flags[4] > 0.0;
  report_problems(flags);
  return {neighbor_list_expired(list_, flags[0], particles_.size()), flags[5] > 0.0};
}

void Simulation::rebuild() {
  ScopedRegion r(timers_, Region::kNeighborBuild);
  if (!pending_cuts_[0].empty()) {
    // New cuts (check_balance), reached in stages that move no cut more than half the
    // partner reach: then every body's new owner is a partner (it is within that distance
    // plus its motion since the last rebuild, < skin, of its old subdomain), and each stage
    // migrates the bodies.
    const Cuts from = domain_.cuts(), to = std::move(pending_cuts_);
    pending_cuts_ = {};
    double most = 0.0;
    for (int a = 0; a < 3; ++a)
      for (std::size_t k = 0; k < to[a].size(); ++k)
        most = std::max(most, std::fabs(to[a][k] - from[a][k]));
    balanced_.largest_shift = std::max(balanced_.largest_shift, most);
    const int stages =
        std::max(1, static_cast<int>(std::ceil(most / (0.5 * domain_.partner_reach()))));
    for (int s = 1; s <= stages; ++s) {
      Cuts cuts = to;
      if (s < stages)
        for (int a = 0; a < 3; ++a)
          for (std::size_t k = 1; k + 1 < to[a].size(); ++k)
            cuts[a][k] = from[a][k] + (to[a][k] - from[a][k]) * s / stages;
      domain_ = Domain(scene_.box, domain_.grid(), comm_.rank(), domain_.shadow_reach(),
                       domain_.partner_reach(), std::move(cuts));
      if (s < stages && comm_.size() > 1) migrate();  // the last stage migrates below
    }
    ++balanced_.shifts;
  }
  if (comm_.size() > 1) redistribute();
  build_neighbor_list(list_, particles_, particles_.size(), owned_, scene_.box, scene_.shape);
  index_bodies();
}

// Contacts at the midpoint; an overlap beyond the tolerance is kept for the agreement.
DetectionStats Simulation::detect() {
  ScopedRegion r(timers_, Region::kDetect);
  const DetectionStats detected =
      detect_contacts(particles_, scene_.box, scene_.shape, list_, contacts_);
  note_detection(detected);
  return detected;
}

void Simulation::note_detection(const DetectionStats &detected) {
  ++detections_;
  detections_watched_ += detected.watched;
  if (!(detected.max_depth <= scene_.max_overlap)) {
    pending_depth_ = std::isnan(detected.max_depth) ? 1e300 : detected.max_depth;
    pending_step_ = step_ + 1;
  }
}

// A contact crosses a rank boundary when one of its bodies is a shadow here or has shadow
// copies elsewhere: only then does another rank see it or need its result.
bool Simulation::touches_boundary() const {
  if (comm_.size() == 1) return false;
  for (const Contact &c : contacts_)
    if (shared_[c.i] || shared_[c.j]) return true;
  return false;
}

void Simulation::report_pending_problems() {
  std::vector<double> flags{0.0, pending_depth_, pending_unresolved_,
                            static_cast<double>(pending_step_)};
  if (comm_.size() > 1) flags = comm_.max("agree", flags);
  report_problems(flags);
}

// flags: [1] deepest overlap beyond the tolerance, [2] unresolvable cluster, [3] its step.
void Simulation::report_problems(const std::vector<double> &flags) {
  if (flags[1] > 0.0)
    fail(fmt::format(
        "step {}: overlap depth {:.4g} D exceeds run.max_overlap = {:g} D at run.dt = {:g}; "
        "the time step is too large for these velocities, try run.dt = {:g}",
        static_cast<long long>(flags[3]), flags[1] >= 1e300 ? NAN : flags[1], scene_.max_overlap,
        scene_.dt, scene_.dt / 4));
  if (flags[2] > 0.0)
    fail(fmt::format(
        "step {}: a cluster of touching bodies across ranks ({} contacts seen by its owner) "
        "reached no rank that holds it in full, so it was not resolved; run with fewer ranks "
        "(larger subdomains) or a smaller run.dt (now {:g})",
        static_cast<long long>(flags[3]), static_cast<long long>(flags[2]), scene_.dt));
}

void Simulation::check_balance() {
  const auto &grid = domain_.grid();
  double load = static_cast<double>(advanced());
  if (balance_.mode == BalanceMode::kTime) {
    // Compute time: the free flight and the detection, ~90 % of a step and free of waits
    // for other ranks (list builds, the thermostat and resolution include exchanges).
    const double busy = timers_.seconds(Region::kIntegrate) + timers_.seconds(Region::kDetect);
    load = std::max(0.0, busy - busy_mark_);
    busy_mark_ = busy;
  }
  // Loads per slab along each axis, and in all: exact sums, so every rank gets the same bits
  // and computes the same cuts.
  const auto c = domain_.coords(comm_.rank());
  std::vector<ExactSum> sums(static_cast<std::size_t>(grid[0] + grid[1] + grid[2]) + 1);
  sums[static_cast<std::size_t>(c[0])].add(load);
  sums[static_cast<std::size_t>(grid[0] + c[1])].add(load);
  sums[static_cast<std::size_t>(grid[0] + grid[1] + c[2])].add(load);
  sums.back().add(load);
  sums = comm_.sum("balance", sums);
  const double builds =
      static_cast<double>(std::max<std::int64_t>(1, timers_.calls(Region::kNeighborBuild)));
  const std::vector<double> most =
      comm_.max("balance", {load, timers_.seconds(Region::kNeighborBuild) / builds});
  const double mean = sums.back().value() / comm_.size();
  if (!(mean > 0.0)) return;
  const double imbalance = most[0] / mean - 1.0;
  if (balanced_.checks == 0) balanced_.first_imbalance = imbalance;
  ++balanced_.checks;
  balanced_.last_imbalance = imbalance;
  balanced_.max_imbalance = std::max(balanced_.max_imbalance, imbalance);
  if (!(imbalance > balance_.threshold)) return;

  Cuts cuts = domain_.cuts();
  bool moved = false;
  int first = 0;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> loads;
    for (int k = 0; k < grid[a]; ++k)
      loads.push_back(sums[static_cast<std::size_t>(first + k)].value());
    first += grid[a];
    if (grid[a] < 2) continue;
    const double side = cuts[a].back();
    // Slabs no thinner than half the even share (more partners, more shadows). The rebuild
    // moves the cuts in stages (rebuild()), so any shift is allowed.
    const auto next = balanced_cuts(cuts[a], loads, 0.5 * side / grid[a], side);
    for (std::size_t k = 0; k < next.size(); ++k)
      moved = moved || std::fabs(next[k] - cuts[a][k]) > 1e-3 * side / grid[a];
    cuts[a] = next;
  }
  if (!moved) return;
  pending_cuts_ = std::move(cuts);
  // Counted bodies are exact: take the new cuts at once. Time: only when the time the ranks
  // lost waiting in the last interval exceeds what a rebuild costs; else at the next one.
  force_rebuild_ = balance_.mode == BalanceMode::kBodies || most[0] - mean > most[1];
}

// Bodies whose centres left the subdomain go to their new owner (a partner); the old
// shadows are dropped.
void Simulation::migrate() {
  const auto &partners = domain_.partners();
  const std::size_t np = partners.size();
  particles_.resize(owned_);
  std::vector<std::vector<char>> out(np);
  for (std::size_t i = 0; i < owned_; ++i) {
    const int to = domain_.owner_of(particles_.position(i));
    if (to == comm_.rank()) continue;
    const std::size_t slot = partner_slot(partners, to);
    if (slot == np || partners[slot] != to)
      fail(fmt::format("body {} moved beyond the neighbouring subdomains (to rank {})",
                       particles_.id[i], to));
    pack_body(out[slot], particles_, i);
  }
  {
    std::vector<std::uint32_t> keep;
    for (std::size_t i = 0; i < owned_; ++i)
      if (domain_.owner_of(particles_.position(i)) == comm_.rank())
        keep.push_back(static_cast<std::uint32_t>(i));
    particles_.permute(keep);
    particles_.resize(keep.size());
  }
  const auto arrived = comm_.exchange("migrate", partners, out);
  for (const auto &buf : arrived)
    for (std::size_t off = 0; off < buf.size();) unpack_body(buf, off, particles_);
  owned_ = particles_.size();
}

// Migration of bodies that left the subdomain, then fresh shadow copies for every partner
// within the halo, each carrying the list of ranks that hold it.
void Simulation::redistribute() {
  migrate();
  const auto &partners = domain_.partners();
  const std::size_t np = partners.size();
  std::vector<std::vector<char>> out(np);
  holding_.clear();
  for (std::size_t i = 0; i < owned_; ++i) {
    Holding h{comm_.rank(), {}};
    for (int r : partners)
      if (domain_.reaches(particles_.position(i), particles_.axis(i), scene_.shape.half_length(),
                          r))
        h.holders.push_back(r);
    for (int r : h.holders) {
      auto &buf = out[partner_slot(partners, r)];
      pack_body(buf, particles_, i);
      pack(buf, static_cast<std::int32_t>(h.holders.size()));
      for (int q : h.holders) pack(buf, static_cast<std::int32_t>(q));
    }
    holding_[particles_.id[i]] = std::move(h);
  }
  const auto shadows = comm_.exchange("shadows", partners, out);
  for (std::size_t k = 0; k < np; ++k)
    for (std::size_t off = 0; off < shadows[k].size();) {
      unpack_body(shadows[k], off, particles_);
      Holding h{partners[k], {}};
      const auto count = unpack<std::int32_t>(shadows[k], off);
      for (std::int32_t q = 0; q < count; ++q)
        h.holders.push_back(unpack<std::int32_t>(shadows[k], off));
      holding_[particles_.id.back()] = std::move(h);
    }
}

// Local index by id (for other ranks' results) and which bodies other ranks hold; one rank
// needs neither (the map cost ~1 ms per rebuild of the paper scene).
void Simulation::index_bodies() {
  index_.clear();
  shared_.assign(particles_.size(), 0);
  if (comm_.size() == 1) return;
  index_.reserve(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i)
    index_[particles_.id[i]] = static_cast<std::uint32_t>(i);
  for (std::size_t i = 0; i < particles_.size(); ++i)
    shared_[i] = i >= owned_ || !holding_.at(particles_.id[i]).holders.empty();
}

namespace {

constexpr std::uint32_t kDegreeUnknown = 0xffffffffu;
constexpr std::size_t kNone = static_cast<std::size_t>(-1);

// What a rank knows in one step of the clusters that span ranks: bodies (velocities, and
// the contact count their owner detected) and contacts, from its own detection and from the
// records its partners sent. A contact seen by two ranks carries the same bits on both (same
// bodies, same arithmetic), and so does a body's velocity, so duplicates are dropped by id.
struct ClusterRecords {
  struct Body {
    std::int64_t id = 0;
    std::uint32_t degree = kDegreeUnknown;  // from the owner
    double motion[6] = {};                  // v, w
  };
  std::vector<Body> bodies;       // by id after tidy()
  std::vector<Contact> contacts;  // canonical after tidy(); i and j unused

  // Sorts and drops duplicates, keeping a body's owner's count where any record has it.
  void tidy() {
    std::sort(bodies.begin(), bodies.end(), [](const Body &a, const Body &b) {
      return a.id != b.id ? a.id < b.id : a.degree < b.degree;
    });
    bodies.erase(std::unique(bodies.begin(), bodies.end(),
                             [](const Body &a, const Body &b) { return a.id == b.id; }),
                 bodies.end());
    std::sort(contacts.begin(), contacts.end(), canonical_less);
    contacts.erase(std::unique(contacts.begin(), contacts.end(),
                               [](const Contact &a, const Contact &b) {
                                 return a.id_i == b.id_i && a.id_j == b.id_j;
                               }),
                   contacts.end());
  }
  // Position of body `id` (present after tidy()).
  std::uint32_t at(std::int64_t id) const {
    return static_cast<std::uint32_t>(
        std::lower_bound(bodies.begin(), bodies.end(), id,
                         [](const Body &b, std::int64_t v) { return b.id < v; }) -
        bodies.begin());
  }
};

// A body's v and w as one record's six doubles, and back.
void read_motion(const Particles &p, std::size_t i, double (&m)[6]) {
  const double v[6] = {p.vx[i], p.vy[i], p.vz[i], p.wx[i], p.wy[i], p.wz[i]};
  std::copy(std::begin(v), std::end(v), m);
}

void write_motion(Particles &p, std::size_t i, const double (&m)[6]) {
  p.set_velocity(i, {m[0], m[1], m[2]});
  p.set_angular_velocity(i, {m[3], m[4], m[5]});
}

void pack_vec(std::vector<char> &buf, const Vec3 &v) {
  pack(buf, v.x);
  pack(buf, v.y);
  pack(buf, v.z);
}

Vec3 unpack_vec(const std::vector<char> &buf, std::size_t &off) {
  Vec3 v;
  v.x = unpack<double>(buf, off);
  v.y = unpack<double>(buf, off);
  v.z = unpack<double>(buf, off);
  return v;
}

// What a message carries of a cluster. A record (the contacts exchange): the bodies (id,
// owner's contact count or kDegreeUnknown, v, w) and the contacts (everything the solver
// reads, and the impulse: 0 before resolution). Results (more than two ranks): the bodies'
// new velocities (id, v, w) and the contacts' impulses (ids, impulse).
enum class Wire { kRecord, kResults };

void pack_cluster(std::vector<char> &buf, const ClusterRecords::Body *bodies, std::size_t nb,
                  const Contact *const *contacts, std::size_t nc, Wire wire) {
  const bool record = wire == Wire::kRecord;
  pack(buf, static_cast<std::int32_t>(nb));
  for (std::size_t k = 0; k < nb; ++k) {
    pack(buf, bodies[k].id);
    if (record) pack(buf, bodies[k].degree);
    for (double m : bodies[k].motion) pack(buf, m);
  }
  pack(buf, static_cast<std::int32_t>(nc));
  for (std::size_t k = 0; k < nc; ++k) {
    const Contact *c = contacts[k];
    pack(buf, c->id_i);
    pack(buf, c->id_j);
    if (record) {
      for (const Vec3 *v : {&c->normal, &c->arm_i, &c->arm_j, &c->separation}) pack_vec(buf, *v);
      pack(buf, c->depth);
      pack(buf, c->inverse_mass);
    }
    pack(buf, c->impulse);
  }
}

void unpack_clusters(const std::vector<char> &buf, ClusterRecords &r, Wire wire) {
  const bool record = wire == Wire::kRecord;
  for (std::size_t off = 0; off < buf.size();) {
    const auto nb = unpack<std::int32_t>(buf, off);
    for (std::int32_t k = 0; k < nb; ++k) {
      ClusterRecords::Body b;
      b.id = unpack<std::int64_t>(buf, off);
      if (record) b.degree = unpack<std::uint32_t>(buf, off);
      for (double &m : b.motion) m = unpack<double>(buf, off);
      r.bodies.push_back(b);
    }
    const auto nc = unpack<std::int32_t>(buf, off);
    for (std::int32_t k = 0; k < nc; ++k) {
      Contact c;
      c.id_i = unpack<std::int64_t>(buf, off);
      c.id_j = unpack<std::int64_t>(buf, off);
      if (record) {
        for (Vec3 *v : {&c.normal, &c.arm_i, &c.arm_j, &c.separation}) *v = unpack_vec(buf, off);
        c.depth = unpack<double>(buf, off);
        c.inverse_mass = unpack<double>(buf, off);
      }
      c.impulse = unpack<double>(buf, off);
      r.contacts.push_back(c);
    }
  }
}

// The clusters of tidy records: contacts grouped by connected bodies (contact indices in
// canonical order, cluster by cluster), each complete when every body's owner's count is
// known and equals the contacts listed for it.
struct RecordClusters {
  std::vector<std::uint32_t> order;  // contact indices grouped by cluster
  std::vector<std::uint32_t> start;  // cluster c is order[start[c] .. start[c + 1])
  std::vector<std::uint32_t> cluster_of_body;
  std::vector<char> complete;

  std::size_t count() const { return start.empty() ? 0 : start.size() - 1; }
};

void cluster_records(const ClusterRecords &r, RecordClusters &rc) {
  const std::size_t nb = r.bodies.size(), nc = r.contacts.size();
  std::vector<std::uint32_t> parent(nb), degree(nb, 0), root_of(nc);
  std::iota(parent.begin(), parent.end(), 0u);
  const auto root = [&](std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const Contact &c : r.contacts) {
    const std::uint32_t i = r.at(c.id_i), j = r.at(c.id_j);
    ++degree[i];
    ++degree[j];
    const std::uint32_t a = root(i), b = root(j);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
  for (std::size_t k = 0; k < nc; ++k) root_of[k] = root(r.at(r.contacts[k].id_i));
  rc.order.resize(nc);
  std::iota(rc.order.begin(), rc.order.end(), 0u);
  std::stable_sort(rc.order.begin(), rc.order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return root_of[a] < root_of[b]; });
  rc.start.clear();
  std::vector<std::uint32_t> number(nb, kDegreeUnknown);
  for (std::size_t k = 0; k < nc; ++k)
    if (k == 0 || root_of[rc.order[k]] != root_of[rc.order[k - 1]]) {
      number[root_of[rc.order[k]]] = static_cast<std::uint32_t>(rc.start.size());
      rc.start.push_back(static_cast<std::uint32_t>(k));
    }
  rc.start.push_back(static_cast<std::uint32_t>(nc));
  rc.complete.assign(rc.count(), 1);
  rc.cluster_of_body.assign(nb, kDegreeUnknown);
  for (std::uint32_t b = 0; b < nb; ++b) {
    if (degree[b] == 0) continue;  // a body of no contact (none are sent)
    const std::uint32_t c = rc.cluster_of_body[b] = number[root(b)];
    if (r.bodies[b].degree != degree[b]) rc.complete[c] = 0;
  }
}

}  // namespace

// Clusters with a body that other ranks hold (shadows, or owned bodies with shadow copies):
// every rank detects exactly the contacts of the bodies it owns (the pair list keeps the
// pairs with an owned body), so a cluster's contacts are the union of its owners' records.
// In one exchange each rank sends, for each such cluster it sees, its contacts, the
// velocities of the bodies and the contact counts of the bodies it owns, to every owner and
// holder of those bodies. A rank merges what it gets with its own; a merged cluster is
// complete when every body's count is its owner's, and then the rank resolves it itself:
// the same contacts in the same order with the same velocities give the same bits on every
// rank, so no results travel. With two ranks every rank that holds a body of a cluster gets
// all of it this way (ARCHITECTURE.md, step 4). With more, a cluster can reach a rank only
// in part; a second exchange then sends every resolved cluster's velocities and impulses to
// all partners. An owned body left in an unresolved cluster is an error, reported
// collectively at the next step. Returns the solver's statistics of the clusters counted
// here (those whose first contact's lower-id body this rank owns).
ResolutionStats Simulation::resolve_across_ranks(const ContactClusters &cc,
                                                 const std::vector<char> &local) {
  const auto &partners = domain_.partners();
  ClusterRecords records;
  std::vector<int> targets;
  // The ranks other than this one that own or hold body `id` (if this rank holds it).
  const auto add_targets = [&](std::int64_t id) {
    const auto h = holding_.find(id);
    if (h == holding_.end()) return;
    if (h->second.owner != comm_.rank()) targets.push_back(h->second.owner);
    for (int r : h->second.holders)
      if (r != comm_.rank()) targets.push_back(r);
  };
  const auto unique_targets = [&] {
    std::sort(targets.begin(), targets.end());
    targets.erase(std::unique(targets.begin(), targets.end()), targets.end());
  };
  std::vector<std::vector<char>> &out = spanning_out_;
  out.resize(partners.size());
  for (auto &o : out) o.clear();
  std::vector<const Contact *> mine;
  for (std::size_t c = 0; c < cc.count(); ++c) {
    if (local[c]) continue;
    const std::size_t first_body = records.bodies.size();
    mine.clear();
    targets.clear();
    for (std::size_t k = cc.start[c]; k < cc.start[c + 1]; ++k) {
      const Contact &ct = contacts_[cc.order[k]];
      mine.push_back(&ct);
      records.contacts.push_back(ct);
      for (std::uint32_t i : {ct.i, ct.j}) {
        ClusterRecords::Body b;
        b.id = particles_.id[i];
        if (std::any_of(records.bodies.begin() + static_cast<long>(first_body),
                        records.bodies.end(),
                        [&](const ClusterRecords::Body &o) { return o.id == b.id; }))
          continue;
        b.degree = i < owned_ ? cc.degree[cc.find(i)] : kDegreeUnknown;
        read_motion(particles_, i, b.motion);
        records.bodies.push_back(b);
        add_targets(b.id);
      }
    }
    unique_targets();
    for (int r : targets)
      pack_cluster(out[partner_slot(partners, r)], records.bodies.data() + first_body,
                   records.bodies.size() - first_body, mine.data(), mine.size(), Wire::kRecord);
  }
  for (const auto &buf : comm_.exchange("contacts", partners, out))
    unpack_clusters(buf, records, Wire::kRecord);
  records.tidy();
  RecordClusters rc;
  cluster_records(records, rc);

  // The complete clusters with a body this rank advances, on a scratch set of their bodies:
  // those this rank owns first, so that the solver counts the clusters whose first contact's
  // lower-id body is owned here.
  const auto local_index = [&](std::int64_t id) -> std::size_t {
    const auto it = index_.find(id);
    return it == index_.end() || it->second >= advanced() ? kNone : it->second;
  };
  std::vector<std::size_t> where(records.bodies.size());
  for (std::size_t b = 0; b < records.bodies.size(); ++b)
    where[b] = local_index(records.bodies[b].id);
  std::vector<char> take(rc.count(), 0);
  for (std::size_t b = 0; b < records.bodies.size(); ++b)
    if (where[b] != kNone && rc.cluster_of_body[b] != kDegreeUnknown)
      take[rc.cluster_of_body[b]] = 1;  // held here
  for (std::size_t c = 0; c < rc.count(); ++c) {
    take[c] = take[c] && rc.complete[c];
    if (results_exchange_)  // tests: only the rank that counts the cluster resolves it
      take[c] = take[c] && where[records.at(records.contacts[rc.order[rc.start[c]]].id_i)] < owned_;
  }
  // Scratch slots: owned bodies first, each group in id order (records are by id).
  std::vector<std::uint32_t> slot(records.bodies.size(), kDegreeUnknown);
  std::size_t counted = 0, n = 0;
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t b = 0; b < records.bodies.size(); ++b) {
      const std::uint32_t c = rc.cluster_of_body[b];
      if (c == kDegreeUnknown || !take[c] || (where[b] < owned_) != (pass == 0)) continue;
      slot[b] = static_cast<std::uint32_t>(n++);
      if (pass == 0) counted = n;
    }
  Particles &work = spanning_bodies_;
  work.resize(n);
  for (std::size_t b = 0; b < records.bodies.size(); ++b) {
    if (slot[b] == kDegreeUnknown) continue;
    work.id[slot[b]] = records.bodies[b].id;
    write_motion(work, slot[b], records.bodies[b].motion);
  }
  std::vector<Contact> solved;
  for (const Contact &ct : records.contacts) {  // canonical order
    const std::uint32_t i = records.at(ct.id_i);
    if (slot[i] == kDegreeUnknown) continue;
    solved.push_back(ct);
    solved.back().i = slot[i];
    solved.back().j = slot[records.at(ct.id_j)];
  }
  const ResolutionStats stats =
      resolve_clusters(work, scene_.shape, solved, find_clusters(solved), {}, solver_, counted);
  ++spanning_.exchanges;
  for (std::size_t c = 0; c < rc.count(); ++c) {
    if (!take[c]) continue;
    ++spanning_.resolved;
    spanning_.multi_contact += rc.start[c + 1] - rc.start[c] > 1;
    bool remote = false;
    for (std::size_t k = rc.start[c]; k < rc.start[c + 1]; ++k) {
      const Contact &ct = records.contacts[rc.order[k]];
      remote =
          remote || (where[records.at(ct.id_i)] >= owned_ && where[records.at(ct.id_j)] >= owned_);
    }
    spanning_.put_together += remote;
  }

  // The results: velocities of the bodies held here, impulses of this rank's contacts.
  std::vector<char> &settled = settled_;
  settled.resize(particles_.size(), 0);
  const std::size_t first_settled = shared_in_.size();
  const auto set_body = [&](std::size_t i, const double(&m)[6]) {
    if (i == kNone || settled[i]) return;
    write_motion(particles_, i, m);
    shared_in_.push_back(static_cast<std::uint32_t>(i));  // motion constants due (midpoint)
    settled[i] = 1;
  };
  const auto set_impulse = [&](const Contact &probe, double impulse) {
    const auto it = std::lower_bound(contacts_.begin(), contacts_.end(), probe, canonical_less);
    if (it != contacts_.end() && it->id_i == probe.id_i && it->id_j == probe.id_j)
      it->impulse = impulse;
  };
  for (std::size_t b = 0; b < records.bodies.size(); ++b) {
    if (slot[b] == kDegreeUnknown) continue;
    double m[6];
    read_motion(work, slot[b], m);
    set_body(where[b], m);
  }
  for (const Contact &ct : solved) set_impulse(ct, ct.impulse);

  if (comm_.size() > 2 || results_exchange_) {
    // Clusters that reached a rank only in part: the velocities and impulses of every
    // cluster resolved here, to the owners and holders of its bodies that this rank knows
    // (duplicates carry the same bits).
    std::vector<std::vector<char>> &results = spanning_out_;
    for (auto &o : results) o.clear();
    std::vector<std::vector<std::uint32_t>> members(rc.count());
    for (std::size_t b = 0; b < records.bodies.size(); ++b)
      if (slot[b] != kDegreeUnknown) members[rc.cluster_of_body[b]].push_back(slot[b]);
    std::vector<ClusterRecords::Body> done;
    std::vector<const Contact *> impulses;
    for (std::size_t c = 0; c < rc.count(); ++c) {
      if (!take[c]) continue;
      done.clear();
      impulses.clear();
      targets.clear();
      for (std::uint32_t k : members[c]) {
        ClusterRecords::Body body;
        body.id = work.id[k];
        read_motion(work, k, body.motion);
        done.push_back(body);
        add_targets(body.id);
      }
      for (std::size_t k = rc.start[c]; k < rc.start[c + 1]; ++k) {
        const Contact &probe = records.contacts[rc.order[k]];
        impulses.push_back(&*std::lower_bound(solved.begin(), solved.end(), probe, canonical_less));
      }
      unique_targets();
      for (int r : targets)
        pack_cluster(results[partner_slot(partners, r)], done.data(), done.size(), impulses.data(),
                     impulses.size(), Wire::kResults);
    }
    for (const auto &in : comm_.exchange("results", partners, results)) {
      ClusterRecords got;
      unpack_clusters(in, got, Wire::kResults);
      for (const ClusterRecords::Body &b : got.bodies) {
        const std::size_t i = local_index(b.id);
        spanning_.from_results += i != kNone && !settled[i];
        set_body(i, b.motion);
      }
      for (const Contact &ct : got.contacts) set_impulse(ct, ct.impulse);
    }
  }
  for (std::size_t c = 0; c < cc.count(); ++c) {
    if (local[c]) continue;
    for (std::size_t k = cc.start[c]; k < cc.start[c + 1]; ++k) {
      const Contact &ct = contacts_[cc.order[k]];
      for (std::uint32_t i : {ct.i, ct.j})
        if (i < owned_ && !settled[i]) {
          pending_unresolved_ =
              std::max(pending_unresolved_, static_cast<double>(cc.start[c + 1] - cc.start[c]));
          pending_step_ = step_ + 1;
        }
    }
  }
  for (std::size_t k = first_settled; k < shared_in_.size(); ++k) settled[shared_in_[k]] = 0;
  return stats;
}

void Simulation::apply_thermostat() {
  const double ke = kinetic_energy();
  if (!std::isfinite(ke) || ke <= 0.0)
    fail(
        fmt::format("step {}: kinetic energy is {} (NaN or infinite velocities) at run.dt = {:g}; "
                    "try a smaller run.dt",
                    step_, ke, scene_.dt));
  thermostat_.correction_sum += ke / kinetic_target_ - 1.0;
  ++thermostat_.applications;
  // Shadows are scaled too, by the same factor: they stay bit-identical to their owners.
  scale_velocities(particles_, particles_.size(), std::sqrt(kinetic_target_ / ke));
}

IntervalTotals Simulation::pending_interval() {
  IntervalTotals t = interval_;
  if (comm_.size() == 1) return t;
  const auto sums = comm_.sum("checkpoint", {t.virial, t.solver_energy_change});
  t.virial = sums[0];
  t.solver_energy_change = sums[1];
  sum_counts_over_ranks(t, "checkpoint");  // steps: every rank counts every step already
  return t;
}

void Simulation::restore_interval(const IntervalTotals &totals) {
  interval_ = comm_.is_root() ? totals : IntervalTotals{};
  interval_.steps = totals.steps;  // every rank counts every step
}

IntervalTotals Simulation::take_interval() {
  IntervalTotals out = interval_;
  interval_ = IntervalTotals{};
  return out;
}

double Simulation::kinetic_energy() {
  const KineticEnergy local = hardrod::kinetic_energy(particles_, owned_, scene_.shape);
  const auto sums = comm_.sum("kinetic_energy", {local.translational, local.rotational});
  ExactSum total = sums[0];
  total += sums[1];
  return total.value();
}

Observation Simulation::observe() {
  Observation o;
  o.step = step_;
  const IntervalTotals t = take_interval();
  const AxisMoments m = axis_moments(particles_, owned_);
  const KineticEnergy ke = hardrod::kinetic_energy(particles_, owned_, scene_.shape);
  const auto sums = comm_.sum("observe", {m.xx, m.xy, m.xz, m.yy, m.yz, m.zz, ke.translational,
                                          ke.rotational, t.virial, t.solver_energy_change});
  const OrderParameter q = order_parameter(moments_from(sums, scene_.n));
  o.order_parameter = q.S;
  o.director = q.director;
  ExactSum e = sums[6];
  e += sums[7];
  o.kinetic_energy = e.value();
  const double dof =
      static_cast<double>(scene_.shape.degrees_of_freedom()) * static_cast<double>(scene_.n) - 3.0;
  o.temperature = 2.0 * o.kinetic_energy / dof;
  o.totals = t;
  o.totals.virial = sums[8];
  o.totals.solver_energy_change = sums[9];
  sum_counts_over_ranks(o.totals, "observe");
  return o;
}

void Simulation::sum_counts_over_ranks(IntervalTotals &t, const char *name) {
  if (comm_.size() == 1) return;
  for (long long *v : {&t.collisions, &t.narrow_phase_tests, &t.contacts, &t.multi_contact_bodies,
                       &t.clusters, &t.solver_unconverged})
    *v = comm_.sum(name, *v);
  const auto mx = comm_.max(name, {t.max_depth, static_cast<double>(t.solver_iterations_max)});
  t.max_depth = mx[0];
  t.solver_iterations_max = static_cast<long long>(mx[1]);
}

void Simulation::verify_bodies() {
  // Owned bodies: gathered at rank 0, which checks 0..n-1 once each.
  std::vector<char> mine;
  for (std::size_t i = 0; i < owned_; ++i) pack(mine, particles_.id[i]);
  const std::vector<char> all = comm_.gather("verify", mine);
  std::string problem;
  if (comm_.is_root()) {
    std::vector<std::int64_t> ids;
    for (std::size_t off = 0; off < all.size();) ids.push_back(unpack<std::int64_t>(all, off));
    std::sort(ids.begin(), ids.end());
    if (static_cast<long long>(ids.size()) != scene_.n)
      problem = fmt::format("{} bodies owned in total, expected {}", ids.size(), scene_.n);
    for (std::size_t k = 0; problem.empty() && k < ids.size(); ++k)
      if (ids[k] != static_cast<std::int64_t>(k))
        problem = fmt::format(
            "id {} is {}", ids[k],
            k > 0 && ids[k] == ids[k - 1] ? "owned twice" : "out of place (a body was lost)");
  }
  // Shadows: each rank checks its copies against their owners' bodies, gathered at rank 0
  // and sent back to everyone as one block (debug only: this moves every body).
  std::vector<char> owned_state;
  for (std::size_t i = 0; i < owned_; ++i) pack_body(owned_state, particles_, i);
  std::vector<char> everything = comm_.gather("verify", owned_state);
  long long size = static_cast<long long>(everything.size());
  size = comm_.sum("verify", comm_.is_root() ? size : 0LL);
  everything.resize(static_cast<std::size_t>(size));
  comm_.broadcast("verify", everything);
  Particles reference;
  for (std::size_t off = 0; off < everything.size();) unpack_body(everything, off, reference);
  std::unordered_map<std::int64_t, std::size_t> where;
  for (std::size_t i = 0; i < reference.size(); ++i) where[reference.id[i]] = i;
  long long mismatches = 0;
  for (std::size_t i = owned_; i < advanced(); ++i) {  // the shadows this rank advances
    const auto it = where.find(particles_.id[i]);
    if (it == where.end()) {
      ++mismatches;
      continue;
    }
    const std::size_t k = it->second;
    for (auto [a, b] : {std::pair{&particles_.x, &reference.x},
                        {&particles_.y, &reference.y},
                        {&particles_.z, &reference.z},
                        {&particles_.ex, &reference.ex},
                        {&particles_.vx, &reference.vx},
                        {&particles_.wz, &reference.wz}})
      if ((*a)[i] != (*b)[k]) {
        ++mismatches;
        break;
      }
  }
  mismatches = comm_.sum("verify", mismatches);
  if (problem.empty() && mismatches > 0)
    problem = fmt::format("{} shadow copies differ from their owners' bodies", mismatches);
  const long long failed = comm_.sum("verify", problem.empty() ? 0LL : 1LL);
  if (failed > 0)
    throw std::logic_error(fmt::format("step {}: body bookkeeping broken: {}", step_,
                                       problem.empty() ? "(see rank 0)" : problem));
}

OrderParameter Simulation::order() {
  const AxisMoments m = axis_moments(particles_, owned_);
  return order_parameter(
      moments_from(comm_.sum("observe", {m.xx, m.xy, m.xz, m.yy, m.yz, m.zz}), scene_.n));
}

FourierOrderTensor Simulation::fourier_order(int kmax) {
  // Owned bodies in id order: the sums then round the same way whatever order the pair-list
  // builds left them in, so a resumed run accumulates the same bits as an uninterrupted one.
  Particles sorted = particles_;
  sorted.resize(owned_);
  std::vector<std::uint32_t> by_id(owned_);
  std::iota(by_id.begin(), by_id.end(), 0u);
  std::sort(by_id.begin(), by_id.end(),
            [&](std::uint32_t a, std::uint32_t b) { return sorted.id[a] < sorted.id[b]; });
  sorted.permute(by_id);
  FourierOrderTensor q = fourier_order_tensor(sorted, owned_, scene_.box, kmax);
  if (comm_.size() == 1) return q;
  // Ranks' partial sums travel as doubles and are added at rank 0 in rank order.
  std::vector<char> mine;
  for (const auto &mode : q.sums)
    for (const auto &c : mode) {
      pack(mine, c.real());
      pack(mine, c.imag());
    }
  for (double f : q.fourth_moments) pack(mine, f);
  const std::vector<char> all = comm_.gather("fourier", mine);
  if (!comm_.is_root()) return q;
  q.bodies = scene_.n;
  for (auto &mode : q.sums) mode.fill({0.0, 0.0});
  q.fourth_moments.fill(0.0);
  for (std::size_t off = 0; off < all.size();) {
    for (auto &mode : q.sums)
      for (auto &c : mode) {
        const double re = unpack<double>(all, off);
        const double im = unpack<double>(all, off);
        c += std::complex<double>(re, im);
      }
    for (double &f : q.fourth_moments) f += unpack<double>(all, off);
  }
  return q;
}

AngularCounts Simulation::angular_distribution(const Vec3 &director, int bins) {
  AngularCounts local = angular_counts(particles_, owned_, director, bins);
  if (comm_.size() == 1) return local;
  AngularCounts global = local;
  for (auto &c : global.counts) c = comm_.sum("observe", c);
  global.total = comm_.sum("observe", local.total);
  global.invalid = comm_.sum("observe", local.invalid);
  return global;
}

Particles Simulation::gather_bodies() {
  std::vector<char> mine;
  mine.reserve(owned_ * kBodyBytes);
  for (std::size_t i = 0; i < owned_; ++i) pack_body(mine, particles_, i);
  const std::vector<char> all = comm_.gather("gather", mine);
  Particles bodies;
  if (!comm_.is_root()) return bodies;
  const std::size_t total = all.size() / kBodyBytes;
  bodies.resize(total);
  for (std::size_t k = 0, off = 0; k < total; ++k) unpack_body_at(all, off, bodies, k);
  // Ids are 0..n-1 (every start numbers the bodies so): body k goes to row id[k], no sort.
  // Anything else (not a permutation) is sorted, as a check costs one pass.
  std::vector<std::uint32_t> order(total, 0);
  std::vector<char> seen(total, 0);
  bool dense = true;
  for (std::size_t k = 0; k < total && dense; ++k) {
    const std::int64_t id = bodies.id[k];
    dense = id >= 0 && static_cast<std::size_t>(id) < total && !seen[static_cast<std::size_t>(id)];
    if (dense) {
      seen[static_cast<std::size_t>(id)] = 1;
      order[static_cast<std::size_t>(id)] = static_cast<std::uint32_t>(k);
    }
  }
  if (!dense) {
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(),
              [&](std::uint32_t a, std::uint32_t b) { return bodies.id[a] < bodies.id[b]; });
  }
  bodies.permute(order);
  return bodies;
}

std::string Simulation::state_checksum() {
  const Particles p = gather_bodies();
  const std::uint64_t hash = body_hash(p);
  // Rank 0 computed it; a sum with zeros from the other ranks gives it to everyone.
  ExactSum h;
  if (comm_.is_root()) h = ExactSum::from_raw(static_cast<Int128>(hash), false);
  const ExactSum all = comm_.sum("checksum", h);
  return fmt::format("{:016x}", static_cast<std::uint64_t>(all.raw()));
}

}  // namespace hardrod
