// The neighbour list's build (see the header): the bodies sorted by cell, the pairs found
// (pair_search.cpp), the first ring kept, the pairs indexed by body and the watches armed.
#include "kernels/neighbor_list.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <limits>

#include "kernels/pair_search.hpp"

namespace hardrod {

namespace {

// Keeps the pairs with an owned body, and stores the shadows in them (the "first ring")
// before the other shadows, in their order, so the per-step passes advance [0, list.active).
// Every contact this rank detects then has an owned body, and every contact of an owned body
// is detected here: the contacts of a cluster that spans ranks are put together from their
// owners' records (MidpointStep::resolve_across_ranks). Shadows past list.active are not
// advanced until the next rebuild replaces them.
void keep_first_ring(NeighborList &list, Particles &p, std::size_t count, std::size_t owned) {
  std::vector<std::uint8_t> ring1(count, 0);
  const std::size_t npairs = list.pair_count();
  for (std::size_t k = 0; k < npairs; ++k) {
    const std::uint32_t a = list.pairs[k].first, b = list.pairs[k].second;
    if (a < owned) ring1[b] = 1;
    if (b < owned) ring1[a] = 1;
  }
  std::vector<std::uint32_t> order(owned), where(count);
  for (std::uint32_t i = 0; i < owned; ++i) order[i] = where[i] = i;
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t i = owned; i < count; ++i)
      if ((ring1[i] != 0) == (pass == 0)) {
        where[i] = static_cast<std::uint32_t>(order.size());
        order.push_back(static_cast<std::uint32_t>(i));
      }
    if (pass == 0) list.active = order.size();  // owned bodies and the first ring
  }
  p.permute(order);
  std::size_t kept = 0;
  for (std::size_t k = 0; k < npairs; ++k) {
    ListedPair pair = list.pairs[k];
    if (pair.first >= owned && pair.second >= owned) continue;
    pair.first = where[pair.first];
    pair.second = where[pair.second];
    list.pairs[kept++] = pair;
  }
  list.pairs.resize(kept);
}

// Bodies sorted by cell (owned ones first): neighbours in space are neighbours in memory
// for every later pass. Ids travel with the bodies. The cell list then names the bodies by
// their new indices (the cells and their counts are those of the same positions; within a
// cell the owned bodies still come first, each group in rising order, as binning the new
// order gives); with one rank a cell's bodies are one contiguous index range.
void sort_bodies_by_cell(CellList &cells, Particles &p, std::size_t count, std::size_t owned) {
  std::vector<std::uint32_t> perm, where(count);
  perm.reserve(count);
  for (std::uint32_t b : cells.order)
    if (b < owned) where[b] = static_cast<std::uint32_t>(perm.size()), perm.push_back(b);
  for (std::uint32_t b : cells.order)
    if (b >= owned) where[b] = static_cast<std::uint32_t>(perm.size()), perm.push_back(b);
  p.permute(perm);
  for (std::uint32_t &b : cells.order) b = where[b];
}

}  // namespace

void build_neighbor_list(NeighborList &list, Particles &p, std::size_t count, std::size_t owned,
                         const Box &box, const Shape &shape) {
  const double reach = shape.diameter + list.skin;
  build_cell_list(list.cells, p, count, box, shape.length + reach, true);
  sort_bodies_by_cell(list.cells, p, count, owned);
  find_pairs(p, box, shape, list.cells, list.skin, owned, list.pairs);
  list.active = count;
  if (count > owned) keep_first_ring(list, p, count, owned);
  list.watched_steps = 0;
  list.near.valid = list.near.off = false;
  if (list.unarmed_builds > 0) {  // the full pass until the next build: no watches to set
    --list.unarmed_builds;
    index_pairs(list);
    list.watching = false;
  } else {
    arm_watches(list);
  }
  std::fill(p.motion_bound.begin(), p.motion_bound.begin() + static_cast<long>(count), 0.0);
  list.bodies = count;
  ++list.builds;
}

// A counting sort of the pair ends by body.
void index_pairs(NeighborList &list) {
  const std::size_t npairs = list.pair_count();
  const std::size_t n = list.active;
  list.pairs_start.assign(n + 1, 0);
  for (std::size_t k = 0; k < npairs; ++k) {
    ++list.pairs_start[list.pairs[k].first + 1];
    ++list.pairs_start[list.pairs[k].second + 1];
  }
  for (std::size_t i = 0; i < n; ++i) list.pairs_start[i + 1] += list.pairs_start[i];
  list.pair_index.resize(2 * npairs);
  list.pair_partner.resize(2 * npairs);
  std::vector<std::uint32_t> next(list.pairs_start.begin(), list.pairs_start.end() - 1);
  for (std::size_t k = 0; k < npairs; ++k) {
    const std::uint32_t a = list.pairs[k].first, b = list.pairs[k].second;
    const std::uint32_t at_a = next[a]++, at_b = next[b]++;
    list.pair_index[at_a] = list.pair_index[at_b] = static_cast<std::uint32_t>(k);
    list.pair_partner[at_a] = b;
    list.pair_partner[at_b] = a;
  }
  list.pairs_end.assign(list.pairs_start.begin() + 1, list.pairs_start.end());
}

void arm_watches(NeighborList &list) {
  const std::size_t n = list.active;
  for (ListedPair &pair : list.pairs) pair.allowance_first = 0.5f * pair.recheck_at;
  index_pairs(list);
  list.watch.resize(n);
  list.flagged.assign(n + 8, 0);  // room for the last word's read
  list.watching = true;
  list.near.valid = false;
#pragma omp parallel for schedule(static) if (static_cast <long>(n) > kParallelBodies)
  for (std::size_t i = 0; i < n; ++i) {
    double w = std::numeric_limits<double>::infinity();
    for (std::uint32_t a = list.pairs_start[i]; a < list.pairs_start[i + 1]; ++a)
      w = std::min(w, list.pairs[list.pair_index[a]].allowance(static_cast<std::uint32_t>(i)));
    list.watch[i] = w;
  }
}

double largest_motion_bound(const Particles &p, std::size_t count) {
  double largest = 0.0;
  for (std::size_t i = 0; i < count; ++i) largest = std::max(largest, p.motion_bound[i]);
  return largest;
}

bool neighbor_list_expired(const NeighborList &list, double largest_bound, std::size_t count) {
  if (list.builds == 0 || list.bodies != count) return true;
  return 2.0 * largest_bound >= list.skin - kDistanceSafetyMargin;
}

}  // namespace hardrod
