// The walk over the listed pairs (see the header): the watched scan in a team of threads, the
// near pairs, and the full pass.
#include "kernels/pair_scan.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>

namespace hardrod {

namespace {

// Due pairs measured a batch at a time: the measure's batches (kernels/due_distances.hpp).
constexpr std::size_t kDueChunk = 256;

// Lower `target` to `value` if that is smaller. Several threads may lower one body's watch
// in a step; the minimum does not depend on their order.
void lower_to(double &target, double value) {
  std::atomic_ref<double> t(target);
  double now = t.load(std::memory_order_relaxed);
  while (value < now && !t.compare_exchange_weak(now, value, std::memory_order_relaxed)) {
  }
}

// Pass 1 of the watched detection over bodies [lo, hi): flag the bodies whose motion bound
// (plus `allowance`, the measure's) reached their watch (a vector compare) and list them in
// `raised`, skipping eight clear flags at a time. Returns the number of pair ends of the
// listed bodies.
inline long flag_block(long lo, long hi, const double *bound, double allowance, const double *watch,
                       std::uint8_t *flagged, const std::uint32_t *start,
                       std::vector<std::uint32_t> &raised) {
  long ends = 0;
#pragma omp simd
  for (long i = lo; i < hi; ++i) flagged[i] = bound[i] + allowance >= watch[i];
  for (long w = lo; w < hi; w += 8) {
    std::uint64_t word;
    std::memcpy(&word, flagged + w, sizeof word);
    if (word == 0) continue;
    for (long i = w; i < std::min(hi, w + 8); ++i)
      if (flagged[i]) {
        raised.push_back(static_cast<std::uint32_t>(i));
        ends += start[i + 1] - start[i];
      }
  }
  return ends;
}

// Body i's new watch: its smallest allowance over its pairs (+infinity without pairs).
inline double smallest_allowance(const NeighborList &list, std::uint32_t i) {
  double w = std::numeric_limits<double>::infinity();
  for (std::uint32_t a = list.pairs_start[i]; a < list.pairs_start[i + 1]; ++a)
    w = std::min(w, list.pairs[list.pair_index[a]].allowance(i));
  return w;
}

// The pairs of the flagged bodies `raised` whose slack is used up (with `spare`, twice
// the measure's allowance, added to the bounds), into `due`; a pair of two flagged bodies is
// visited from its first body only.
void list_due_of(const NeighborList &list, const double *bound, double spare,
                 const std::uint8_t *flagged, const std::vector<std::uint32_t> &raised,
                 std::vector<std::uint32_t> &due) {
  const ListedPair *pairs = list.pairs.data();
  const std::uint32_t *start = list.pairs_start.data(), *index = list.pair_index.data();
  // The pairs' records are scattered through the list: ask for all of them first.
  for (const std::uint32_t i : raised)
    for (std::uint32_t a = start[i]; a < start[i + 1]; ++a) __builtin_prefetch(&pairs[index[a]], 1);
  due.clear();
  for (const std::uint32_t i : raised)
    for (std::uint32_t a = start[i]; a < start[i + 1]; ++a) {
      const ListedPair &pair = pairs[index[a]];
      const std::uint32_t f = pair.first, s = pair.second;
      if (s == i && flagged[f]) continue;  // visited from its first body
      if ((bound[f] + bound[s]) + spare >= pair.recheck_at) due.push_back(index[a]);
    }
}

// Every visited pair's slack split between its bodies, the rest in proportion to the bounds
// so far: bounds grow about linearly, so both bodies then reach their allowances about when
// the pair's slack is used up (evenly while both bounds are 0). An unflagged partner whose
// allowance shrank lowers its watch (an atomic minimum when `shared_watches`).
void split_slacks(NeighborList &list, const double *bound, const std::uint8_t *flagged,
                  const std::vector<std::uint32_t> &raised, bool shared_watches) {
  ListedPair *pairs = list.pairs.data();
  const std::uint32_t *start = list.pairs_start.data(), *index = list.pair_index.data();
  double *watch = list.watch.data();
  for (const std::uint32_t i : raised)
    for (std::uint32_t a = start[i]; a < start[i + 1]; ++a) {
      ListedPair &pair = pairs[index[a]];
      const std::uint32_t f = pair.first, s = pair.second;
      if (s == i && flagged[f]) continue;
      const double moved = bound[f] + bound[s];
      const double rest = pair.recheck_at - moved;
      pair.allowance_first = static_cast<float>(
          bound[f] + (moved > 0.0 && rest > 0.0 ? rest * (bound[f] / moved) : 0.5 * rest));
      const std::uint32_t other = f == i ? s : f;
      if (flagged[other]) continue;
      if (shared_watches)
        lower_to(watch[other], pair.allowance(other));
      else  // the same minimum without the atomic's fence
        watch[other] = std::min(watch[other], pair.allowance(other));
    }
}

}  // namespace

WatchedTeam::WatchedTeam(int threads)
    : due(static_cast<std::size_t>(threads)),
      ends(static_cast<std::size_t>(threads)),
      tests(static_cast<std::size_t>(threads)),
      depth(static_cast<std::size_t>(threads)) {}

void scan_watched_in_team(const Particles &p, NeighborList &list, WatchedTeam &team,
                          DueMeasure &measure) {
  const long n = static_cast<long>(list.active);
  const double *bound = p.motion_bound.data();
  std::uint8_t *flagged = list.flagged.data();  // n + 8 long (arm_watches)
  const int tid = omp_get_thread_num();
  const int threads = omp_get_num_threads();
  const auto [lo, hi] = team_block(n, tid, threads);
  std::vector<std::uint32_t> raised;  // this block's flagged bodies
  double max_depth = 0.0;

  const double allowance = measure.allowance;
  const long my_ends = flag_block(lo, hi, bound, allowance, list.watch.data(), flagged,
                                  list.pairs_start.data(), raised);
  team.ends[tid] = my_ends;  // once: the threads' entries share a cache line
#pragma omp barrier
  // Every thread takes the same decision from the same sum (no further barrier).
  long all_ends = 0;
  for (int t = 0; t < threads; ++t) all_ends += team.ends[t];
  if (list.watched_share * all_ends > 2 * static_cast<long>(list.pair_count())) {
    raised.clear();
    if (tid == 0) team.watching = false;
  }
  // The pairs whose slack is used up, measured; then every visited pair's slack split.
  std::vector<std::uint32_t> &due = team.due[tid];
  list_due_of(list, bound, 2.0 * allowance, flagged, raised, due);
  if (!due.empty()) measure.measure(tid, p, list, due.data(), due.size(), max_depth);
  split_slacks(list, bound, flagged, raised, threads > 1);
#pragma omp barrier
  for (const std::uint32_t i : raised) list.watch[i] = smallest_allowance(list, i);
  team.tests[tid] = static_cast<long long>(due.size());
  team.depth[tid] = max_depth;
}

namespace {

// How a pass over every pair uses the list's near pairs (NearPairs): not at all (the reference
// pass), or it reads them alone while they hold and makes them again when they do not.
enum class NearUse { none, keep };

DetectionStats all_pairs(const Particles &p, NeighborList &list, DueMeasure &measure, NearUse use);

}  // namespace

DetectionStats finish_watched_scan(const Particles &p, NeighborList &list, WatchedTeam &team,
                                   DueMeasure &measure) {
  if (!team.watching) {  // too many flagged: the full pass, now and until the next build
    list.watching = false;
    if (list.watched_steps == 0) list.unarmed_builds = kUnarmedBuilds;  // at once: not worth it
    return all_pairs(p, list, measure, NearUse::keep);
  }
  DetectionStats out;
  out.watched = true;
  ++list.watched_steps;
  for (std::size_t t = 0; t < team.tests.size(); ++t) {
    out.narrow_phase_tests += team.tests[t];
    out.max_depth = std::max(out.max_depth, team.depth[t]);
  }
  return out;
}

namespace {

// Whether the list's near pairs still hold every pair that can be due: made by a pass with
// the same spare, and no body's bound fell since (a build resets them) nor grew by half their
// reach (with 1e-9 for rounding). One pass over the bodies.
bool near_holds(const NearPairs &near, const double *bound, std::size_t n, double spare) {
  if (!near.valid || near.spare != spare || near.base.size() != n) return false;
  const double *base = near.base.data();
  double largest = 0.0, smallest = 0.0, sum = 0.0;
#pragma omp simd reduction(max : largest) reduction(min : smallest) reduction(+ : sum)
  for (std::size_t i = 0; i < n; ++i) {
    const double g = bound[i] - base[i];
    largest = largest > g ? largest : g;
    smallest = smallest < g ? smallest : g;
    sum += g;  // a NaN, which the extremes would drop, stays in the sum
  }
  return std::isfinite(sum) && smallest >= 0.0 && 2.0 * largest + 1e-9 < near.reach;
}

// The near pairs' reach and base for a pass that makes them: kNearSteps times twice the
// largest per-step path (2 grow) of bodies [0, n). False, and the list's near pairs off until
// its next build, where that reach is more than kNearSkinShare of the skin.
bool start_near(NearPairs &near, const Particles &p, std::size_t n, double skin, double spare) {
  double largest = 0.0;
  const double *grow = p.grow.data();
#pragma omp simd reduction(max : largest)
  for (std::size_t i = 0; i < n; ++i) largest = largest > grow[i] ? largest : grow[i];
  near.reach = kNearSteps * 2.0 * (2.0 * largest);
  near.valid = false;
  if (!(near.reach <= kNearSkinShare * skin)) {
    near.off = true;
    return false;
  }
  near.spare = spare;
  near.base.assign(p.motion_bound.begin(), p.motion_bound.begin() + static_cast<long>(n));
  near.valid = true;
  ++near.made;
  return true;
}

// Pairs at[first, last) (without Indexed: the pair indices themselves) tested for due (their
// bounds, plus `spare`, used up the slack: the others cannot have closed their gap yet), listed
// without a branch and measured a chunk at a time; with Make, those whose slack left is below
// `reach` are listed in `near` too.
template <bool Make, bool Indexed>
void pass_pairs(const Particles &p, NeighborList &list, const std::uint32_t *at, long first,
                long last, DueMeasure &measure, int thread, double spare, double reach,
                std::vector<std::uint32_t> &near, long long &tests, double &max_depth) {
  std::uint32_t due[kDueChunk];
  std::size_t n = 0, m = 0;
  if constexpr (Make) near.resize(static_cast<std::size_t>(last - first));
  const ListedPair *pairs = list.pairs.data();
  const double *bound = p.motion_bound.data();
  for (long q = first; q < last; ++q) {
    // (pairs[q] itself without the index: the loop then steps a pointer, as a 32-bit index
    // would not let it)
    const std::uint32_t k = Indexed ? at[q] : static_cast<std::uint32_t>(q);
    const ListedPair &pair = Indexed ? pairs[k] : pairs[q];
    const double moved = (bound[pair.first] + bound[pair.second]) + spare;
    due[n] = k;
    n += moved >= pair.recheck_at;
    if constexpr (Make) {
      near[m] = k;
      m += pair.recheck_at - moved < reach;
    }
    if (n == kDueChunk) {
      measure.measure(thread, p, list, due, n, max_depth);
      tests += static_cast<long long>(n);
      n = 0;
    }
  }
  if (n > 0) {  // the last chunk
    measure.measure(thread, p, list, due, n, max_depth);
    tests += static_cast<long long>(n);
  }
  if constexpr (Make) near.resize(m);
}

// Which pairs a pass reads: the near pairs alone (`at`, while they hold), or every pair,
// making the near pairs again (`make_near`) where the list keeps them.
struct PassPlan {
  bool use_near = false, make_near = false;
  const std::uint32_t *at = nullptr;
  long count = 0;
  double spare = 0.0;  // twice the measure's allowance
};

PassPlan plan_pass(const Particles &p, NeighborList &list, double allowance, NearUse use) {
  PassPlan plan;
  plan.spare = 2.0 * allowance;
  NearPairs &near = list.near;
  const bool keep = use == NearUse::keep && !near.off;
  plan.use_near = keep && near_holds(near, p.motion_bound.data(), list.active, plan.spare);
  plan.make_near =
      keep && !plan.use_near && start_near(near, p, list.active, list.skin, plan.spare);
  plan.at = plan.use_near ? near.index.data() : nullptr;
  plan.count = static_cast<long>(plan.use_near ? near.index.size() : list.pair_count());
  return plan;
}

// The pass over every listed pair (scan_every_pair), or, with NearUse::keep, over the list's
// near pairs while they hold (near_holds), made again by the full pass when not. The same
// pairs are due either way, measured in list order.
DetectionStats all_pairs(const Particles &p, NeighborList &list, DueMeasure &measure, NearUse use) {
  const int nthreads = omp_get_max_threads();
  measure.start(nthreads);
  // The threads' near pairs, their storage kept from step to step, reached by the team through
  // a reference: inside the parallel region a thread_local name is each thread's own.
  thread_local std::vector<std::vector<std::uint32_t>> near_storage;
  std::vector<std::vector<std::uint32_t>> &near_found = near_storage;
  near_found.resize(static_cast<std::size_t>(nthreads));
  long long tests = 0;
  double max_depth = 0.0;
  const PassPlan plan = plan_pass(p, list, measure.allowance, use);
  const double reach = plan.make_near ? list.near.reach : 0.0;
  int team = 1;
#pragma omp parallel reduction(+ : tests) reduction(max : max_depth) \
    if (static_cast<long>(list.active) > kParallelBodies)
  {
    const int tid = omp_get_thread_num();
    if (tid == 0) team = omp_get_num_threads();
    const auto [lo, hi] = team_block(plan.count, tid, omp_get_num_threads());
    auto &mine_near = near_found[static_cast<std::size_t>(tid)];
    const auto pass = [&](auto make, auto indexed) {
      pass_pairs<decltype(make)::value, decltype(indexed)::value>(
          p, list, plan.at, lo, hi, measure, tid, plan.spare, reach, mine_near, tests, max_depth);
    };
    if (plan.make_near)
      pass(std::true_type{}, std::false_type{});
    else if (plan.use_near)
      pass(std::false_type{}, std::true_type{});
    else
      pass(std::false_type{}, std::false_type{});
  }
  if (plan.make_near) {  // the threads' blocks in order: list order
    list.near.index.clear();
    for (int t = 0; t < team; ++t)
      list.near.index.insert(list.near.index.end(), near_found[t].begin(), near_found[t].end());
  }
  DetectionStats out{tests, max_depth};
  out.near = plan.use_near;
  return out;
}

}  // namespace

// Each thread takes one block of bodies (team_block: the list's body order is cell order,
// so mostly its own pairs too) and makes three passes over it:
//  1. flag the bodies whose motion bound reached their watch (a vector compare), and list
//     them, skipping eight clear flags at a time;
//  2. for each flagged body, its pairs: measure those whose bounds used up the slack, and
//     split every visited pair's remaining slack between its two bodies. A pair of two
//     flagged bodies is visited from its first body only, so each pair has one writer.
//     An unflagged partner whose allowance shrank lowers its watch to it (atomic minimum);
//  3. each flagged body's watch becomes its smallest allowance.
// Pairs of two unflagged bodies are not read: their bounds sum to less than the slack
// (arm_watches). The pairs measured, and so the slacks, are those of a pass over the
// whole list (scan_every_pair), for any thread count.
DetectionStats scan_pairs(const Particles &p, NeighborList &list, DueMeasure &measure) {
  if (!list.watching) return all_pairs(p, list, measure, NearUse::keep);
  // Threaded exactly when the integration is (particles.hpp).
  const int nthreads = team_threads(static_cast<long>(list.active));
  measure.start(nthreads);
  WatchedTeam team(nthreads);
#pragma omp parallel num_threads(nthreads)
  scan_watched_in_team(p, list, team, measure);
  return finish_watched_scan(p, list, team, measure);
}

DetectionStats scan_every_pair(const Particles &p, NeighborList &list, DueMeasure &measure) {
  return all_pairs(p, list, measure, NearUse::none);
}

}  // namespace hardrod
