// Verlet pair list with a skin and lazy, per-pair re-checks (the broad phase).
// Every pair whose axis segments were closer than D + skin at build time is listed with the
// segment distance it had. Each body carries a motion bound (how far any point of it has
// moved since the build); the distance of a pair can shrink by at most the sum of the two
// bounds, so a pair needs the narrow phase only when that sum reaches its recorded slack.
// Pairs not listed cannot touch while the two largest bounds sum to less than the skin (or,
// once extended body by body on one rank, while each bound is below its body's reach:
// list_extension.hpp).
// The set of contacts found is therefore exactly the brute-force set, whatever the skin.
//
// Watches: so that a step need not read every pair, each pair's slack is split into two
// allowances, one per body, and each body watches the smallest of its allowances. While
// neither body's bound has reached its watch, the sum of the bounds is below the slack and
// the pair is not read at all. A step reads the bodies' bounds and watches, and only the
// pairs of bodies whose bound reached their watch (contact_detection.cpp): it measures the
// same pairs as a pass over the whole list would, in far fewer reads.
// Threading: the build is split over cells; per-thread pair blocks are concatenated.
#pragma once

#include <cmath>
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

// Taken off the second body's allowance of a pair (in D), so that two bounds each below its
// allowance also sum, after rounding, to less than the slack (bounds and slacks are < 10 D,
// where a rounding is < 2e-15).
inline constexpr double kAllowanceCushion = 1e-12;

// Builds that skip the watches after a list whose watches gave up at their first step.
inline constexpr int kUnarmedBuilds = 7;

// A pair read through the watches costs ~20x a pair in a pass over the whole list (scattered
// reads and branches against a stream): past 1/16 of the pair ends, the pass is cheaper.
inline constexpr long kWatchedShare = 16;

// A slack as the list stores it: a float below `slack`, by one or two of its roundings. A pair
// is then measured a little earlier than its double slack says (by under 2.4e-7 of the slack),
// never later, so the pairs found within reach are the same. The slack less 2^-23 of itself
// (and 1e-30, for the subnormals), rounded to nearest, is below it whatever the rounding
// (its error is at most 2^-24 relative, or 2^-150 absolute): no branch, as a step renews the
// slacks of thousands of pairs and the sign of the rounding is a coin toss. For |slack| below
// 1e38; a NaN stays a NaN.
inline float slack_below(double slack) {
  return static_cast<float>(slack - std::abs(slack) * 0x1p-23 - 1e-30);
}

// One listed pair, in one 16-byte record so that a step visiting a few pairs reads one cache
// line for each (the fields are read and written together), and a pass over the whole list
// streams two thirds of what double slacks took.
struct ListedPair {
  std::uint32_t first = 0, second = 0;  // local indices
  // Narrow phase needed once motion_bound[first] + motion_bound[second] >= recheck_at
  // (written through slack_below).
  float recheck_at = 0.0f;
  // The first body's share of the slack (its allowance); the second body's allowance is
  // recheck_at - allowance_first - kAllowanceCushion, in double: any split keeps the two
  // allowances' sum below the slack.
  float allowance_first = 0.0f;

  double second_allowance() const {
    return static_cast<double>(recheck_at) - static_cast<double>(allowance_first) -
           kAllowanceCushion;
  }
  // Body b's allowance (b is first or second).
  double allowance(std::uint32_t b) const {
    return b == first ? static_cast<double>(allowance_first) : second_allowance();
  }
};
static_assert(sizeof(ListedPair) == 16);

// The listed pairs near to due, for the steps that pass over every pair (NeighborList::
// watching false): made by such a pass, the pairs whose slack left, recheck_at less the two
// bounds (and the spare, twice the measure's allowance, kernels/pair_scan.hpp), was below `reach`,
// in list order. A pair left out can fall due only once its two bounds have grown by `reach` since,
// so the next passes read these alone while twice the largest growth since (bound - base) stays
// below it. reach is kNearSteps times twice the largest per-step path then (2 grow). They pay
// where that is a small part of the skin (the nematic at dt 1e-3: 0.13 D of 1 D); where it is
// more than kNearSkinShare of the skin (hard spheres at dt 4e-3: 0.32 D of 0.5), they would
// hold most pairs and last a few steps: the list goes without.
inline constexpr double kNearSteps = 8.0;
inline constexpr double kNearSkinShare = 0.5;
struct NearPairs {
  std::vector<std::uint32_t> index;
  std::vector<double> base;  // the bodies' motion bounds when made
  double reach = 0.0;
  double spare = 0.0;
  bool valid = false;
  bool off = false;    // not worth it for this list (kNearSkinShare)
  long long made = 0;  // times made (a statistic)
};

struct NeighborList {
  double skin = 0.3;
  std::vector<ListedPair> pairs;
  // The pairs of body i, by index: pair_index[pairs_start[i] .. pairs_end[i]); and beside
  // each, the pair's other body (pair_partner[a]), so that a walk over a body's partners
  // reads one run of memory instead of a scattered pair record each. After a build
  // pairs_end[i] is pairs_start[i + 1]; an extension (list_extension.hpp) moves the runs of
  // the bodies it gives new pairs to the end, so the walks of the exact method read pairs_end.
  // The watched detection, which an extension turns off, reads pairs_start[i + 1].
  std::vector<std::uint32_t> pairs_start, pairs_end, pair_index, pair_partner;
  // Body i's pairs need a look once motion_bound[i] >= watch[i], the smallest allowance of
  // body i over its pairs (+infinity without pairs). [0, active).
  std::vector<double> watch;
  std::vector<std::uint8_t> flagged;  // scratch of the detection: bound reached the watch
  // True from a build until the first step at which the flagged bodies have more than
  // 1/watched_share of the list's pair ends; from then until the next build, the steps pass
  // over every pair (detect_contacts) and the watches are not kept. watched_share = 1
  // keeps the watches whatever the cost (tests, benchmarks).
  bool watching = false;
  long watched_share = kWatchedShare;
  // Steps detected through the watches since the build, and builds left that skip arming
  // them: where they gave up at the first step after a build (the exact method's bounds hold
  // a whole step's flight, so most bodies reach their watch at once), the next
  // kUnarmedBuilds builds do not arm them (arming is a pass over every pair for nothing), and
  // the one after tries again.
  long long watched_steps = 0;
  int unarmed_builds = 0;
  CellList cells;
  long long builds = 0;
  std::size_t bodies = 0;  // body count the list was built for
  // Bodies [0, active) are owned or listed with an owned body: the per-step passes advance
  // only these. The rest are shadows no listed pair involves (see build_neighbor_list).
  std::size_t active = 0;

  NearPairs near;

  std::size_t pair_count() const { return pairs.size(); }
};

// Index the pairs by body over bodies [0, list.active): pairs_start, pair_index and
// pair_partner, each body's pairs in list order (arm_watches calls it).
void index_pairs(NeighborList &list);

// Split every pair's slack evenly between its two bodies (at zero bounds, as after a
// build), index the pairs by body and set the watches. build_neighbor_list calls it; a test
// that edits the slacks calls it again.
void arm_watches(NeighborList &list);

// Rebuild the list over bodies [0, count) and reset their motion bounds to zero. Sorts
// the bodies by cell, owned ones [0, owned) and shadows [owned, count) separately, so the
// owned bodies stay first (they keep their ids; every result downstream is ordered by id,
// not by storage).
// With shadows (count > owned) only the pairs with an owned body are kept, and the shadows
// in them (the "first ring") are stored right after the owned bodies, [owned, list.active);
// the other shadows are moved behind them and are not advanced. A contact between two
// shadows is detected by their owners, which send it where a cluster needs it
// (MidpointStep::resolve_across_ranks).
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
