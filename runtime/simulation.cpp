// The state of a run and its time step: construction, advance() through the phases that
// runtime/simulation.hpp numbers, the step's one agreement, the local resolution and the
// step's tallies, the thermostat, and the problems reported on every rank. The other
// phases' runtime parts have their own files: decomposition.cpp, spanning_clusters.cpp,
// balance_check.cpp; observables and diagnostics too.
#include "runtime/simulation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "kernels/initial_state.hpp"
#include "kernels/isotropic_start.hpp"
#include "kernels/rotor_constraints.hpp"
#include "kernels/thermostat.hpp"
#include "runtime/hoomd_gsd.hpp"
#include "runtime/signals.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

// A frame from a file may hold overlapping bodies (a damaged or hand-made frame, another
// shape): said here, naming the deepest pair, rather than at the first step as a dt problem.
void check_start_overlaps(const Scene &scene, const Particles &all, const std::string &key,
                          long long frame) {
  Particles copy = all;  // the list build reorders the bodies
  NeighborList list;
  list.skin = 1e-6;
  build_neighbor_list(list, copy, copy.size(), scene.box, scene.shape);
  double deepest = 0.0;
  const ListedPair *worst = nullptr;
  for (const ListedPair &pair : list.pairs)
    if (-pair.recheck_at > deepest) deepest = -pair.recheck_at, worst = &pair;
  if (deepest <= scene.max_overlap) return;
  throw SceneError({fmt::format(
      "{}: frame {}: the start configuration overlaps: bodies {} and {} by {:.4g} D (more than "
      "run.max_overlap = {:g} D); not a hard-body state for L/D = {:g} (another shape, or a "
      "damaged file?)",
      key, frame, copy.id[worst->first], copy.id[worst->second], deepest, scene.max_overlap,
      scene.shape.length / scene.shape.diameter)});
}

// The scene's initial bodies, the same on every rank: on the lattice, compressed from a
// random isotropic state (every rank computes the same, deterministic in the seed), or
// positions and axes from an H5MD frame (n and box must match the scene); fresh velocities.
// A GSD frame (runtime/hoomd_gsd.hpp) brings its velocities if it has any.
Particles initial_bodies(const Scene &scene, bool stoppable) {
  Particles all;
  if (scene.configuration == Configuration::kFile && is_gsd_path(scene.init_file)) {
    all = start_from_gsd(scene);
    check_start_overlaps(scene, all, fmt::format("init.file = \"{}\"", scene.init_file),
                         scene.init_frame);
    return all;
  }
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
    check_start_overlaps(scene, all, key, f.frame);
  } else if (scene.configuration == Configuration::kIsotropic) {
    try {
      CompressionOptions options;
      if (stoppable) options.stop = [] { return stop_signal() != 0; };
      all = make_isotropic(scene.n, scene.shape, scene.box, scene.seed, options);
    } catch (const CompressionStopped &) {
      throw;
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
  configure(initial_bodies(scene_, comm_.size() == 1), parallel);
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
  extend_lists_ = parallel.extend_lists && scene_.method == kExact;
  list_.keep_build_state = extend_lists_;  // what an extension measures (one rank only)
  if (balance_.interval < 1)
    throw SceneError(
        {fmt::format("--balance-interval must be at least 1, got {}", balance_.interval)});
  decompose(all, parallel);
  keep_owned(all);
}

void Simulation::fail(const std::string &message) { throw PhysicsError(message); }

void Simulation::step() { advance(1); }

// Steps in a row: between two steps of one call nothing reads the state, so the second half
// of a step and the first half of the next run as one pass over the bodies (to_midpoint(2):
// the same bits as two passes), except where the rotor constraints or the thermostat act
// between them, or a stop was agreed.
void Simulation::advance(long long count) {
  if (scene_.method == kExact) return advance_exact(count);
  MidpointDetection reached;
  bool at_midpoint = false;  // phase 1 of this step is done already
  // The drift reads each body's motion constants: current from here on, whatever changed the
  // velocities since the last call. Within the call they follow every change: impulses and
  // rebuilds (midpoint), the rotor constraints and the thermostat (phase 7).
  {
    ScopedRegion r(timers_, Region::kIntegrate);
    refresh_motion(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
  }
  for (long long k = 0; k < count; ++k) {
    if (!at_midpoint) reached = to_midpoint(1);  // 1. (with 2. when the list keeps watches)
    midpoint(reached);                           // 2.-5.
    ++step_;
    const bool constrain = step_ % kConstraintInterval == 0;
    const bool thermostat =
        scene_.thermostat_interval > 0 && step_ % scene_.thermostat_interval == 0;
    at_midpoint = k + 1 < count && !constrain && !thermostat && !stop_agreed_;
    if (at_midpoint)
      reached = to_midpoint(2);  // 6., and the next step's 1.
    else
      second_half();                       // 6.
    if (constrain) restore_constraints();  // 7.
    if (thermostat) apply_thermostat();    // 7.
    if (stop_agreed_) return;
    if (balance_.mode != BalanceMode::kOff && comm_.size() > 1 && step_ % balance_.interval == 0)
      check_balance();  // 8.
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

// Phase 6 alone: half_step refreshes every body's motion constants itself, so a step() at a
// time does not depend on the refreshes within a burst, and the tests compare the two (one
// refresh of all bodies per burst, ~2 ns per body).
void Simulation::second_half() {
  ScopedRegion r(timers_, Region::kIntegrate);
  half_step(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
}

// Phase 7: the rotors' constraints (unit axis, w perpendicular to it) against round-off.
void Simulation::restore_constraints() {
  ScopedRegion r(timers_, Region::kIntegrate);
  restore_rotor_constraints(particles_, advanced());
  refresh_motion(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
}

// Phases 2-5, with the bodies at the midpoint of the step.
void Simulation::midpoint(const MidpointDetection &reached) {
  // 2. contacts, found before the step's one reduction so that it can also tell every rank
  // whether any contact touches a rank boundary this step. A rank whose own bounds already
  // expire the list skips this: it knows a rebuild follows.
  DetectionStats detected;
  bool boundary = false;
  if (!neighbor_list_expired(list_, reached.largest_bound, particles_.size())) {
    detected = reached.detected ? reached.stats : detect();
    boundary = touches_boundary();
  }
  // 3.
  Agreement agreed = agree(reached.largest_bound, boundary);
  if (force_rebuild_) {  // new cuts (check_balance; the same decision on every rank)
    agreed.rebuild = true;
    force_rebuild_ = false;
    ++balanced_.forced_rebuilds;
  }
  // 4.
  if (agreed.rebuild) {
    rebuild();
    detected = detect();  // a problem is reported at the next step's agreement
    if (comm_.size() == 1) report_pending_problems();
  }
  // 5.
  std::vector<char> counted(contacts_.size(), 1);
  const ResolutionStats resolved = resolve(agreed, counted);
  // Velocities that changed: the motion constants follow (all after a rebuild, which
  // brings bodies and renews the shadows; else the impulses' bodies, in resolve).
  if (agreed.rebuild) {
    ScopedRegion r(timers_, Region::kIntegrate);
    refresh_motion(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
  }
  tally(detected, resolved, counted);
}

// Phase 5: elastic impulses. Nothing to do in most steps at small dt: no contact here, and
// no exchange, which all ranks must join. Contacts' results travel between ranks only when
// some rank has a contact that involves a shadow or a body that other ranks hold (agreed),
// or the shadows were just renewed. Sets counted[k] for the contacts this rank counts.
ResolutionStats Simulation::resolve(const Agreement &agreed, std::vector<char> &counted) {
  const bool exchange = comm_.size() > 1 && (agreed.boundary || agreed.rebuild);
  ResolutionStats resolved;
  if (contacts_.empty() && !exchange) return resolved;
  ScopedRegion r(timers_, Region::kResolve);
  const ContactClusters clusters = find_clusters(contacts_);
  if (comm_.size() == 1) {
    resolved = resolve_clusters(particles_, scene_.shape, contacts_, clusters, {}, solver_);
    interval_.multi_contact_bodies += clusters.multi_contact_bodies;
  } else {
    resolved = resolve_on_ranks(clusters, exchange);
    // Each contact is counted once in the whole system: by the owner of its lower id.
    for (std::size_t k = 0; k < contacts_.size(); ++k) counted[k] = contacts_[k].i < owned_;
    // Owned bodies only: their contacts are all seen here, each counted once.
    for (std::size_t b = 0; b < clusters.bodies.size(); ++b)
      interval_.multi_contact_bodies += clusters.bodies[b] < owned_ && clusters.degree[b] > 1;
  }
  if (!agreed.rebuild) {  // the bodies of the impulses, here and from other ranks
    changed_.clear();
    for (const Contact &c : contacts_) {
      changed_.push_back(c.i);
      changed_.push_back(c.j);
    }
    changed_.insert(changed_.end(), shared_in_.begin(), shared_in_.end());
    refresh_motion(particles_, changed_, scene_.shape, 0.5 * scene_.dt);
  }
  shared_in_.clear();
  return resolved;
}

// Phase 5 on several ranks. Without an exchange every cluster is made of bodies only this
// rank holds: resolved here (5a). With one, the clusters with a body other ranks hold are
// put together across ranks (5b, resolve_across_ranks).
ResolutionStats Simulation::resolve_on_ranks(const ContactClusters &clusters, bool exchange) {
  std::vector<char> local(clusters.count(), 1);
  if (exchange)
    for (std::size_t c = 0; c < clusters.count(); ++c)
      for (std::size_t k = clusters.start[c]; k < clusters.start[c + 1] && local[c]; ++k) {
        const Contact &ct = contacts_[clusters.order[k]];
        local[c] = !shared_[ct.i] && !shared_[ct.j];
      }
  ResolutionStats resolved =
      resolve_clusters(particles_, scene_.shape, contacts_, clusters, local, solver_, owned_);
  if (exchange) {
    const ResolutionStats across = resolve_across_ranks(clusters, local);
    resolved.clusters += across.clusters;
    resolved.iterations_max = std::max(resolved.iterations_max, across.iterations_max);
    resolved.unconverged += across.unconverged;
    interval_.solver_energy_change.add(across.energy_change);
  }
  return resolved;
}

// The step's contribution to the interval totals.
void Simulation::tally(const DetectionStats &detected, const ResolutionStats &resolved,
                       const std::vector<char> &counted) {
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
  return {neighbor_list_expired(list_, flags[0], particles_.size()), flags[5] > 0.0, flags[0]};
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
  detections_near_ += detected.near;
  if (!(detected.max_depth <= scene_.max_overlap)) {
    pending_depth_ = std::isnan(detected.max_depth) ? 1e300 : detected.max_depth;
    pending_step_ = step_ + 1;
  }
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

// Phase 7: velocities scaled to the target kinetic energy.
void Simulation::apply_thermostat() {
  ScopedRegion r(timers_, Region::kThermostat);
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
  refresh_motion(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
}

}  // namespace hardrod
