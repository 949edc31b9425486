// The exact method's collisions within a step (see the header): the entry points, which hand a
// step to the one queue (exact_queue.cpp) or solve it by clusters (exact_clusters.cpp); the
// overrun check between ranks' clusters, and the landing of the flown bodies.
#include "kernels/exact/exact_collisions.hpp"

#include <algorithm>
#include <iterator>

#include "kernels/exact/exact_events.hpp"
#include "kernels/exact/overrun_check.hpp"

namespace hardrod {

namespace {

using namespace exact_events;

// The step's events in one queue (solve_in_one_queue, `confined` as there); false where the
// queue gave up and the caller goes by cluster.
bool in_one_queue(const Particles &p, const Box &box, const Shape &shape, const NeighborList &list,
                  const std::vector<Candidate> &candidates, const std::vector<BodyPair> &joins,
                  bool confined, double dt, const ExactSettings &settings, ExactScratch &scratch,
                  ExactStats &stats, std::vector<FlownBody> &flown) {
  scratch.label.resize(list.active, kNone);
  const Context cx{p, box, box.inverse_length(), shape, list, scratch.label, dt, settings, nullptr};
  return solve_in_one_queue(cx, candidates, joins, confined, scratch, stats, flown);
}

// The candidates' counts (ExactStats): spares are neither candidates nor apart.
void count_candidates(const std::vector<Candidate> &candidates, ExactStats &stats) {
  for (const Candidate &c : candidates) {
    stats.spares += c.spare;
    stats.apart += c.apart && !c.spare;
  }
  stats.candidates = static_cast<long long>(candidates.size()) - stats.spares;
}

// The candidates the clusters take: all but the spares (kept in `kept` where there are any).
const std::vector<Candidate> &for_clusters(const std::vector<Candidate> &candidates,
                                           const ExactStats &stats, std::vector<Candidate> &kept) {
  if (stats.spares == 0) return candidates;
  kept.clear();
  std::copy_if(candidates.begin(), candidates.end(), std::back_inserter(kept),
               [](const Candidate &c) { return !c.spare; });
  return kept;
}

}  // namespace

ExactStats collide_exactly(const Particles &p, const Box &box, const Shape &shape,
                           const NeighborList &list, const std::vector<Candidate> &candidates,
                           double dt, const ExactSettings &settings, ExactScratch &scratch,
                           std::vector<FlownBody> &flown) {
  ExactStats stats;
  flown.clear();
  count_candidates(candidates, stats);
  if (candidates.empty()) {
    stats.queued = settings.one_queue;
    return stats;
  }
  if (settings.one_queue && in_one_queue(p, box, shape, list, candidates, {}, false, dt, settings,
                                         scratch, stats, flown)) {
    stats.queued = 1;
    return stats;
  }
  std::vector<Candidate> kept;
  solve_by_clusters(p, box, shape, list, for_clusters(candidates, stats, kept), {}, dt, settings,
                    true, scratch, stats, flown);
  return stats;
}

ExactStats collide_once(const Particles &p, const Box &box, const Shape &shape,
                        const NeighborList &list, const std::vector<Candidate> &candidates,
                        const std::vector<BodyPair> &joins, double dt,
                        const ExactSettings &settings, ExactScratch &scratch,
                        std::vector<FlownBody> &flown) {
  ExactStats stats;
  flown.clear();
  count_candidates(candidates, stats);
  if (candidates.empty() && joins.empty()) return stats;
  if (settings.one_queue && in_one_queue(p, box, shape, list, candidates, joins, true, dt, settings,
                                         scratch, stats, flown))
    return stats;
  std::vector<Candidate> kept;
  solve_by_clusters(p, box, shape, list, for_clusters(candidates, stats, kept), joins, dt, settings,
                    false, scratch, stats, flown);
  return stats;
}

std::vector<BodyPair> overrun_reaches(const Particles &p, const Box &box, const Shape &shape,
                                      const NeighborList &list, const std::vector<FlownBody> &flown,
                                      const std::vector<std::int64_t> &cluster,
                                      std::vector<double> &overrun, const std::vector<char> *from) {
  std::vector<BodyPair> out;
  overrun.resize(std::max(overrun.size(), list.active), 0.0);
  for (const FlownBody &f : flown) overrun[f.body] = f.overrun;
  const Vec3 inverse = box.inverse_length();
  std::vector<Overrunner<std::int64_t>> bodies;
  for (const FlownBody &f : flown)
    if (f.overrun > 0.0 && (from == nullptr || (*from)[f.body]))
      bodies.push_back({f.body, cluster[f.body]});
  OverrunCheck<std::int64_t>(p, box, inverse, shape, list, overrun, cluster.data(), out)
      .run(bodies);
  for (const FlownBody &f : flown) overrun[f.body] = 0.0;
  distinct_pairs(out);
  return out;
}

ExactStats &ExactStats::operator+=(const ExactStats &o) {
  candidates += o.candidates;
  apart += o.apart;
  spares += o.spares;
  clusters += o.clusters;
  largest_cluster = std::max(largest_cluster, o.largest_cluster);
  collisions += o.collisions;
  events += o.events;
  searches += o.searches;
  repredictions += o.repredictions;
  root_iterations += o.root_iterations;
  unconverged += o.unconverged;
  regrown += o.regrown;
  fallbacks += o.fallbacks;
  grazes += o.grazes;
  queued += o.queued;
  extra_pairs += o.extra_pairs;
  kept_apart += o.kept_apart;
  virial += o.virial;
  return *this;
}

namespace {
// An axis or spin component: what a sphere's landing leaves alone.
constexpr bool turning_field(BodyField field) {
  return field == &Particles::ex || field == &Particles::ey || field == &Particles::ez ||
         field == &Particles::wx || field == &Particles::wy || field == &Particles::wz;
}
}  // namespace

void land_flown(Particles &p, const std::vector<FlownBody> &flown, bool turns) {
  // Each write goes to a line of one of thirteen arrays (seven for spheres) that the step's
  // flight has left in no cache at N = 32768: the lines of the bodies a few records on are
  // asked for first.
  constexpr std::size_t kAhead = 4;
  const std::size_t n = flown.size();
  for (std::size_t k = 0; k < n; ++k) {
    if (k + kAhead < n) {
      const std::uint32_t b = flown[k + kAhead].body;
      for (BodyField field : kStateFields)
        if (turns || !turning_field(field)) __builtin_prefetch(&(p.*field)[b], 1);
      __builtin_prefetch(&p.motion_bound[b], 1);
    }
    const FlownBody &f = flown[k];
    p.set_position(f.body, f.x);
    p.set_velocity(f.body, f.v);
    if (turns) {
      p.set_axis(f.body, f.e);
      p.set_angular_velocity(f.body, f.w);
    }
    p.motion_bound[f.body] += f.overrun;
  }
}

}  // namespace hardrod
