// Verlet pair list with a skin and lazy, per-pair re-checks (the broad phase).
// Every pair whose axis segments were closer than D + skin at build time is listed with the
// segment distance it had. Each body carries a motion bound (how far any point of it has
// moved since the build); the distance of a pair can shrink by at most the sum of the two
// bounds, so a pair needs the narrow phase only when that sum reaches its recorded slack.
// Pairs not listed cannot touch while the two largest bounds sum to less than the skin.
// The set of contacts found is therefore exactly the brute-force set, whatever the skin.
// Threading: the build is split over cells; per-thread pair blocks are concatenated.
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/cell_list.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

// Slack on every comparison against floating-point distances (in D): covers the rounding
// of the segment distance and of the accumulated motion bounds, many orders above both.
inline constexpr double kDistanceSafetyMargin = 1e-9;

struct NeighborList {
  double skin = 0.3;
  std::vector<std::uint32_t> first, second;  // pair (first[k], second[k]), local indices
  // Narrow phase needed once motion_bound[first] + motion_bound[second] >= recheck_at.
  std::vector<double> recheck_at;
  CellList cells;
  long long builds = 0;
  std::size_t bodies = 0;  // body count the list was built for
  // Bodies [0, active) are owned or in some listed pair: the per-step passes advance only
  // these. The rest are shadows no listed pair involves (see build_neighbor_list).
  std::size_t active = 0;

  std::size_t pair_count() const { return first.size(); }
};

// Rebuild the list over bodies [0, count) and reset their motion bounds to zero. Sorts
// the bodies by cell, owned ones [0, owned) and shadows [owned, count) separately, so the
// owned bodies stay first (they keep their ids; every result downstream is ordered by id,
// not by storage).
// With shadows (count > owned) only pairs that can matter to this rank's clusters are kept:
// those with an owned body or a shadow listed with an owned body ("first-ring" shadows).
// Shadows of the second ring (listed with a first-ring one) complete the clusters the rank
// resolves; shadows further out are moved behind them, past list.active, and are not
// advanced: their owners resolve their contacts and send the results.
void build_neighbor_list(NeighborList &list, Particles &p, std::size_t count, std::size_t owned,
                         const Box &box, const Shape &shape);
inline void build_neighbor_list(NeighborList &list, Particles &p, std::size_t count, const Box &box,
                                const Shape &shape) {
  build_neighbor_list(list, p, count, count, box, shape);
}

// Largest motion bound of bodies [0, count).
double largest_motion_bound(const Particles &p, std::size_t count);

// True when a pair absent from the list could now be touching (the list must be rebuilt):
// twice the largest motion bound has reached the skin. (Twice the largest rather than the
// two largest, so that ranks holding different bodies decide alike from one max-reduction.)
bool neighbor_list_expired(const NeighborList &list, double largest_bound, std::size_t count);

}  // namespace hardrod
