// The decomposition of the bodies over ranks (runtime/domain.hpp): the grid chosen at start,
// the bodies a rank keeps, and at every rebuild (phase 4, runtime/system.hpp) new cuts
// taken in stages, migration of bodies whose centres left the subdomain, fresh shadow
// copies with the ranks that hold each body, and the index of local bodies by id, with the
// lookups the methods' cross-rank protocols make in it. Not here:
// when cuts move (runtime/balance_check.cpp) and the pair list (kernels/neighbor_list.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "kernels/initial_state.hpp"
#include "kernels/order_tensor.hpp"
#include "kernels/thermostat.hpp"
#include "runtime/body_wire.hpp"
#include "runtime/system.hpp"

namespace hardrod {

// The grid of ranks: the given one, or MPI_Dims_create's, the fewest cuts going to the axis the
// bodies are most aligned with (q's director): rods aligned along an axis need shadows half a
// rod further along it than across.
std::array<int, 3> System::choose_grid(const ParallelOptions &parallel,
                                       const OrderParameter &q) const {
  std::array<int, 3> grid = parallel.grid;
  if (grid[0] * grid[1] * grid[2] == 0) {
    grid = comm_.make_grid({0, 0, 0});  // non-increasing counts
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
  return grid;
}

// The domain on `grid` (the same on every rank), with cuts that share the bodies out where the
// balancer is on (`counts`: the bodies per slab).
void System::decompose(const std::array<int, 3> &grid, const SlabCounts &counts) {
  // A body is shadowed where its axis segment comes within L/2 + D + skin of a subdomain:
  // every point of an owned body's segment stays within L/2 + skin/2 of the subdomain until
  // the next rebuild, and every point of another body moves at most skin/2, so every body
  // that can touch an owned body is held. Partners: any two ranks that can hold one body.
  const Shape &shape = scene_.shape;
  const double shadow_reach = shape.half_length() + shape.diameter + scene_.skin;
  const double partner_reach = 2.0 * (shadow_reach + shape.half_length());
  domain_ = Domain(scene_.box, grid, comm_.rank(), shadow_reach, partner_reach);
  if (balance_.mode != BalanceMode::kOff && comm_.size() > 1)
    domain_ =
        Domain(scene_.box, grid, comm_.rank(), shadow_reach, partner_reach, starting_cuts(counts));
}

// From all bodies, which every rank holds: the grid, the domain, and the bodies this rank owns.
void System::decompose_all(const Particles &all, const ParallelOptions &parallel) {
  const double *at[3] = {all.x.data(), all.y.data(), all.z.data()};
  const double sides[3] = {scene_.box.length.x, scene_.box.length.y, scene_.box.length.z};
  decompose(
      choose_grid(parallel, order_parameter(axis_moments(all, all.size()))),
      [&](int a, const std::vector<double> &cuts) {
        std::vector<double> counts(cuts.size() - 1, 0.0);
        for (std::size_t i = 0; i < all.size(); ++i)
          counts[static_cast<std::size_t>(Domain::slab(cuts, Box::wrap(at[a][i], sides[a])))] +=
              1.0;
        return counts;
      });
  keep_owned(all);
}

// The scene's lattice made where it is owned: each rank places only the sites in its subdomain
// and draws their velocities; the momentum and kinetic energy that fix the drift and the scale
// are exact sums over the ranks. The same bodies, bit for bit, as every rank making all of them
// (initial_bodies) and keeping its own, in memory and time of the rank's share.
void System::start_on_lattice(const ParallelOptions &parallel) {
  const std::array<long long, 3> &lattice = scene_.lattice;
  const int axis = scene_.axis;
  // Every axis along the lattice's: the director of all of them, S = 1.
  OrderParameter q;
  q.S = 1.0;
  q.director = {axis == 0 ? 1.0 : 0.0, axis == 1 ? 1.0 : 0.0, axis == 2 ? 1.0 : 0.0};
  const double sides[3] = {scene_.box.length.x, scene_.box.length.y, scene_.box.length.z};
  decompose(choose_grid(parallel, q), [&](int a, const std::vector<double> &cuts) {
    // The sites along axis a, each standing for the whole plane of sites across it.
    std::vector<double> counts(cuts.size() - 1, 0.0);
    const auto na = static_cast<std::size_t>(a);
    const double spacing = sides[a] / static_cast<double>(lattice[na]);
    const auto plane = static_cast<double>(scene_.n / lattice[na]);
    for (long long i = 0; i < lattice[na]; ++i) {
      const double x = (static_cast<double>(i) + 0.5) * spacing;
      counts[static_cast<std::size_t>(Domain::slab(cuts, Box::wrap(x, sides[a])))] += plane;
    }
    return counts;
  });
  // The sites in this subdomain (a site more each side for the rounding at a cut).
  const auto lo = domain_.lower(comm_.rank()), hi = domain_.upper(comm_.rank());
  std::array<long long, 3> from{}, to{};
  for (std::size_t a = 0; a < 3; ++a) {
    const double spacing = sides[a] / static_cast<double>(lattice[a]);
    from[a] = std::max(0LL, static_cast<long long>(std::floor(lo[a] / spacing - 0.5)) - 1);
    to[a] = std::min(lattice[a], static_cast<long long>(std::ceil(hi[a] / spacing - 0.5)) + 2);
  }
  Particles mine;
  place_lattice_block(mine, scene_.box, lattice, axis, from, to,
                      [&](const Vec3 &x) { return domain_.owner_of(x) == comm_.rank(); });
  const Shape &shape = scene_.shape;
  std::array<ExactSum, 3> momentum = draw_velocities(mine, shape, scene_.seed, scene_.temperature);
  const std::vector<ExactSum> p =
      comm_.sum("setup", std::vector<ExactSum>(momentum.begin(), momentum.end()));
  std::copy(p.begin(), p.end(), momentum.begin());
  remove_drift(mine, momentum, scene_.n);
  const KineticEnergy ke = hardrod::kinetic_energy(mine, mine.size(), shape);
  const std::vector<ExactSum> k = comm_.sum("setup", {ke.translational, ke.rotational});
  scale_to_target(mine, shape, scene_.temperature, scene_.n, KineticEnergy{k[0], k[1]}.total());
  particles_ = std::move(mine);
  owned_ = particles_.size();
}

// Every rank made the same full state: this one keeps the bodies whose centres it owns.
void System::keep_owned(const Particles &all) {
  Particles mine;
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (domain_.owner_of(all.position(i)) != comm_.rank()) continue;
    const std::size_t k = mine.size();
    mine.resize(k + 1);
    mine.id[k] = all.id[i];
    for (BodyField f : kStateFields) (mine.*f)[k] = (all.*f)[i];
  }
  particles_ = std::move(mine);
  owned_ = particles_.size();
}

// Phase 4: bodies to their owners, fresh shadows and a new pair list (with new cuts first
// when the balancer set some).
void System::rebuild() {
  ScopedRegion r(timers_, Region::kNeighborBuild);
  if (!pending_cuts_[0].empty()) take_new_cuts();
  if (comm_.size() > 1) redistribute();
  build_neighbor_list(list_, particles_, particles_.size(), owned_, scene_.box, scene_.shape);
  index_bodies();
}

// New cuts (check_balance), reached in stages that move no cut more than half the partner
// reach: then every body's new owner is a partner (it is within that distance plus its motion
// since the last rebuild, < skin, of its old subdomain), and each stage but the last (which
// redistribute() ends) migrates the bodies.
void System::take_new_cuts() {
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
    if (s < stages && comm_.size() > 1) migrate();
  }
  ++balanced_.shifts;
}

// Bodies whose centres left the subdomain go to their new owner (a partner); the old
// shadows are dropped.
void System::migrate() {
  const auto &partners = domain_.partners();
  const std::size_t np = partners.size();
  particles_.resize(owned_);
  std::vector<std::vector<char>> out(np);
  for (std::size_t i = 0; i < owned_; ++i) {
    const int to = domain_.owner_of(particles_.position(i));
    if (to == comm_.rank()) continue;
    const std::size_t slot = domain_.partner_slot(to);
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
void System::redistribute() {
  migrate();
  const auto &partners = domain_.partners();
  const std::size_t np = partners.size();
  std::vector<std::vector<char>> out(np);
  holding_.clear();
  for (std::size_t i = 0; i < owned_; ++i) {
    Holding h{comm_.rank(), {}};
    domain_.reached_partners(particles_.position(i), particles_.axis(i), scene_.shape.half_length(),
                             h.holders);
    for (int r : h.holders) {
      auto &buf = out[domain_.partner_slot(r)];
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
// needs neither (the map costs a hash insert per body and rebuild).
void System::index_bodies() {
  index_.clear();
  shared_.assign(particles_.size(), 0);
  if (comm_.size() == 1) return;
  index_.reserve(particles_.size());
  for (std::size_t i = 0; i < particles_.size(); ++i)
    index_[particles_.id[i]] = static_cast<std::uint32_t>(i);
  for (std::size_t i = 0; i < particles_.size(); ++i)
    shared_[i] = i >= owned_ || !holding_.at(particles_.id[i]).holders.empty();
}

std::size_t System::advanced_index(std::int64_t id) const {
  const auto it = index_.find(id);
  return it == index_.end() || it->second >= advanced() ? kNotAdvanced : it->second;
}

void System::add_targets(std::int64_t id, std::vector<int> &targets) const {
  const auto h = holding_.find(id);
  if (h == holding_.end()) return;
  if (h->second.owner != comm_.rank()) targets.push_back(h->second.owner);
  for (int r : h->second.holders)
    if (r != comm_.rank()) targets.push_back(r);
}

const System::Holding *System::holding(std::int64_t id) const {
  const auto h = holding_.find(id);
  return h == holding_.end() ? nullptr : &h->second;
}

}  // namespace hardrod
