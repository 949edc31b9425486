// The decomposition of the bodies over ranks (runtime/domain.hpp): the grid chosen at start,
// the bodies a rank keeps, and at every rebuild (phase 4, runtime/system.hpp) new cuts
// taken in stages, migration of bodies whose centres left the subdomain, fresh shadow
// copies with the ranks that hold each body, and the index of local bodies by id, with the
// lookups the methods' cross-rank protocols make in it. Not here:
// when cuts move (runtime/balance_check.cpp) and the pair list (kernels/neighbor_list.hpp).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "kernels/order_tensor.hpp"
#include "runtime/body_wire.hpp"
#include "runtime/system.hpp"

namespace hardrod {

// The grid of ranks and the domain, from all bodies (the same on every rank).
void System::decompose(const Particles &all, const ParallelOptions &parallel) {
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
  if (balance_.mode != BalanceMode::kOff && comm_.size() > 1)
    domain_ =
        Domain(scene_.box, grid, comm_.rank(), shadow_reach, partner_reach, starting_cuts(all));
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
    for (int r : partners)
      if (domain_.reaches(particles_.position(i), particles_.axis(i), scene_.shape.half_length(),
                          r))
        h.holders.push_back(r);
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

}  // namespace hardrod
