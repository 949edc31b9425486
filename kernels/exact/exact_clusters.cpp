// The exact method's collisions by cluster (exact_collisions.hpp): the candidates joined by
// shared bodies into clusters, the event-driven pass through one cluster (a thread each), the
// check that no cluster's overrun reaches another and the clusters joined where one does, and
// the fallback of a cluster past its event cap. What a cluster's pass shares with the one queue
// (exact_queue.cpp) is exact_events.hpp's.
#include <omp.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <iterator>
#include <limits>

#include "kernels/contact_detection.hpp"
#include "kernels/exact/exact_events.hpp"
#include "kernels/exact/overrun_check.hpp"
#include "kernels/union_find.hpp"

namespace hardrod::exact_events {

namespace {

// A candidate as the clusters read it: its bodies (c.i has the lower id), its place in the step's
// array of candidates (their canonical order), and whether it needs its first search (`live`:
// not proven apart, Candidate::apart, or the proof is not trusted, see Partition::first). 16
// bytes beside the cluster's other edges: a pointer into the step's candidates would cost a
// scattered read each, as they are in id order and the clusters in body order.
struct Edge {
  std::uint32_t i = 0, j = 0;
  std::uint32_t at = 0;
  bool live = true;
};

// Up to this many bodies a sphere cluster predicts a changed body against every other one
// (predict_pairs_of) rather than walk its listed pairs: a sphere's search is a closed form, but
// their number grows as the cluster's square, and past about a dozen the walk is cheaper.
constexpr std::size_t kAllSlots = 12;

// One cluster's event-driven pass from the step's start to its end. One per thread, reused
// from cluster to cluster so that a cluster allocates nothing.
class ClusterPass {
 public:
  explicit ClusterPass(const Context &cx) : cx_(cx) {}

  // Cluster `group` of `count` bodies (ascending) and its candidates; its flown bodies are
  // appended to `flown`.
  ExactStats run(std::uint32_t group, const std::uint32_t *bodies, std::size_t count,
                 const Edge *candidates, std::size_t ncandidates, std::vector<FlownBody> &flown) {
    group_ = group;
    bodies_ = bodies;
    count_ = count;
    stats_ = {};
    queue_.clear();
    slots_.clear();
    const bool turns = !cx_.shape.is_sphere();  // (spheres: start_flight)
    for (std::size_t s = 0; s < count; ++s) slots_.add(cx_.p, bodies[s], turns);
    for (std::size_t k = 0; k < ncandidates; ++k)
      if (candidates[k].live) predict(slot(candidates[k].i), slot(candidates[k].j), 0.0, false);
    const long long cap = cx_.settings.events_per_body * static_cast<long long>(count);
    bool fell_back = false;
    while (!queue_.empty()) {
      std::pop_heap(queue_.begin(), queue_.end(), Later());
      const Event ev = queue_.back();
      queue_.pop_back();
      if (ev.version_a != slots_.version[ev.a] || ev.version_b != slots_.version[ev.b]) continue;
      if (++stats_.events > cap * (fell_back ? 2 : 1)) {
        if (fell_back) break;  // chattering on: the rest of the step in free flight
        fall_back(ev.t);
        fell_back = true;
        continue;
      }
      if (ev.resume)
        predict(ev.a, ev.b, ev.t, false);
      else
        collide(ev.a, ev.b, ev.t);
    }
    land(flown);
    return stats_;
  }

 private:
  std::uint32_t slot(std::uint32_t body) const {
    return static_cast<std::uint32_t>(std::lower_bound(bodies_, bodies_ + count_, body) - bodies_);
  }

  // The first contact of slots a and b from t, queued if there is one in the step.
  void predict(std::uint32_t a, std::uint32_t b, double t, bool again) {
    const std::int64_t *id = cx_.p.id.data();
    if (id[bodies_[a]] > id[bodies_[b]]) std::swap(a, b);
    double at = 0.0;
    bool resume = false;
    if (!search_pair(cx_, slots_.flight[a], slots_.flight[b],
                     image_shift(cx_, bodies_[a], bodies_[b]), t, again, stats_, at, resume))
      return;
    queue_.push_back(
        {at, id[bodies_[a]], id[bodies_[b]], a, b, slots_.version[a], slots_.version[b], resume});
    std::push_heap(queue_.begin(), queue_.end(), Later());
  }

  void fly_to(std::uint32_t s, double t) { slots_.fly_to(s, t, cx_.shape.half_length()); }

  // The elastic, frictionless impulse of slots a and b touching at t (a has the lower id),
  // then every listed pair of the two inside the cluster predicted again.
  void collide(std::uint32_t a, std::uint32_t b, double t) {
    const Touch touch =
        slots_.collide(a, b, t, image_shift(cx_, bodies_[a], bodies_[b]), cx_.shape, stats_);
    if (!touch.closing) {
      double from = 0.0;
      if (search_after_graze(cx_, touch, t, from)) predict(a, b, from, true);
      return;
    }
    predict_pairs_of(a, kNone, t);
    predict_pairs_of(b, a, t);
  }

  // f(other) for every listed partner `other` of `body` in this cluster.
  template <class F>
  void each_partner_in_cluster(std::uint32_t body, F &&f) const {
    const NeighborList &list = cx_.list;
    for (std::uint32_t q = list.pairs_start[body]; q < list.pairs_end[body]; ++q) {
      const std::uint32_t other = list.pair_partner[q];
      if (cx_.group_of[other] == group_) f(other);
    }
  }

  // Every listed pair of slot s with a partner in the cluster (but `skip`), from t.
  void predict_pairs_of(std::uint32_t s, std::uint32_t skip, double t) {
    if (count_ == 2) {  // the cluster's one edge is its one listed pair: no walk of the list
      if (1 - s != skip) predict(s, 1 - s, t, true);
      return;
    }
    // Spheres in a small cluster: every other slot, listed or not, rather than the walk of s's
    // partners (a miss on the pair index and one per partner's cluster, where a sphere's search
    // is a closed form). A pair the list does not hold cannot touch before it expires (the
    // step is solved again on a new list if an overrun could carry it that far), and a sphere's
    // search that finds nothing queues nothing, so the events are the same.
    if (count_ <= kAllSlots && cx_.shape.half_length() == 0.0) {
      for (std::uint32_t o = 0; o < count_; ++o)
        if (o != s && o != skip) predict(s, o, t, true);
      return;
    }
    each_partner_in_cluster(bodies_[s], [&](std::uint32_t other) {
      const std::uint32_t o = slot(other);
      if (o != skip) predict(s, o, t, true);
    });
  }

  // Past the event cap at t: the cluster's touching pairs solved together there, once.
  void fall_back(double t) {
    ++stats_.fallbacks;
    Particles scratch;
    scratch.resize(count_);
    for (std::uint32_t s = 0; s < count_; ++s) {
      fly_to(s, t);
      scratch.id[s] = cx_.p.id[bodies_[s]];
      scratch.set_position(s, slots_.flight[s].x);
      scratch.set_axis(s, slots_.flight[s].e);
      scratch.set_velocity(s, slots_.flight[s].v);
      scratch.set_angular_velocity(s, slots_.flight[s].w);
    }
    // Touching: closer than twice the search's tolerance (and the rounding of the flights).
    const double reach = 2.0 * cx_.settings.contact.tolerance + 1e-12;
    std::vector<Contact> touching;
    for (std::uint32_t a = 0; a < count_; ++a)
      each_partner_in_cluster(bodies_[a], [&](std::uint32_t other) {
        Contact c;
        double d = 0.0;
        if (other > bodies_[a] &&
            make_contact(scratch, cx_.box, cx_.inverse, cx_.shape, a, slot(other), c, d, reach))
          touching.push_back(c);
      });
    std::sort(touching.begin(), touching.end(), canonical_less);
    resolve_contacts(scratch, cx_.shape, touching, cx_.settings.solver);
    for (const Contact &c : touching) {  // c.i has the lower id
      if (!(c.impulse > 0.0)) continue;
      const double w = c.impulse * dot(c.normal, c.separation);
      stats_.virial.add(w);
      slots_.virial[c.i].add(w);
      ++stats_.collisions;
      ++slots_.collisions[c.i];
    }
    queue_.clear();
    for (std::uint32_t s = 0; s < count_; ++s) {
      slots_.flight[s].v = scratch.velocity(s);
      slots_.flight[s].w = scratch.angular_velocity(s);
      ++slots_.version[s];
    }
    for (std::uint32_t s = 0; s < count_; ++s) predict_pairs_of(s, kNone, t);
  }

  // The bodies whose velocity changed, flown to the step's end.
  void land(std::vector<FlownBody> &flown) {
    for (std::uint32_t s = 0; s < count_; ++s) {
      if (slots_.version[s] == 0) continue;  // in free flight all step: fly_step moves it
      cx_.overrun[bodies_[s]] =
          slots_.land(s, bodies_[s], cx_.dt, cx_.p, cx_.shape.half_length(), flown).overrun;
    }
  }

  const Context &cx_;
  std::uint32_t group_ = 0;
  const std::uint32_t *bodies_ = nullptr;  // ascending local indices
  std::size_t count_ = 0;
  Slots slots_;               // by slot, the cluster's bodies in their order
  std::vector<Event> queue_;  // a heap, earliest on top
  ExactStats stats_;
};

// The clusters, flat: cluster g's bodies (ascending) are bodies[body_start[g] ..
// body_start[g + 1]), its candidates cands[cand_start[g] .. cand_start[g + 1]). A cluster
// solved again after a join is appended and the old ones marked dead.
struct Partition {
  std::vector<std::uint32_t> bodies;
  std::vector<std::size_t> body_start{0};
  std::vector<Edge> cands;
  std::vector<std::size_t> cand_start{0};
  std::vector<char> alive;
  // Has a live candidate: else nothing happens in it in the step, and its stats and flown
  // bodies are neither written nor read (most of a step's clusters: hard spheres at packing
  // fraction 0.45, ~2950 of ~3900).
  std::vector<char> eventful;
  std::vector<ExactStats> stats;
  std::vector<std::vector<FlownBody>> flown;

  std::size_t count() const { return alive.size(); }

  // The clusters of the joined candidates, in one pass over their bodies `involved`
  // (ascending: a root is its set's smallest index, so it comes before its set's other
  // bodies) and one over the candidates. `screened`: a candidate proven apart is not live.
  void first(std::vector<std::uint32_t> &parent, const std::vector<std::uint32_t> &involved,
             const std::vector<Candidate> &candidates, bool screened,
             std::vector<std::uint32_t> &group_of) {
    std::vector<std::size_t> &size = scratch_;
    size.clear();
    for (const std::uint32_t b : involved) {
      const std::uint32_t r = set_root(parent, b);
      if (r == b) {
        group_of[b] = static_cast<std::uint32_t>(size.size());
        size.push_back(0);
      } else {
        group_of[b] = group_of[r];
      }
      ++size[group_of[b]];
    }
    const std::size_t groups = size.size();
    body_start.assign(groups + 1, 0);
    for (std::size_t g = 0; g < groups; ++g) body_start[g + 1] = body_start[g] + size[g];
    bodies.resize(body_start[groups]);
    std::vector<std::size_t> &at = scratch_;
    at.assign(body_start.begin(), body_start.end() - 1);
    for (const std::uint32_t b : involved) bodies[at[group_of[b]]++] = b;
    cand_start.assign(groups + 1, 0);
    for (const Candidate &c : candidates) ++cand_start[group_of[c.i] + 1];
    for (std::size_t g = 0; g < groups; ++g) cand_start[g + 1] += cand_start[g];
    cands.resize(candidates.size());
    at.assign(cand_start.begin(), cand_start.end() - 1);
    eventful.assign(groups, 0);
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      const Candidate &c = candidates[k];
      const std::uint32_t g = group_of[c.i];
      const bool live = !(screened && c.apart);
      cands[at[g]++] = {c.i, c.j, static_cast<std::uint32_t>(k), live};
      eventful[g] |= live;
    }
    alive.assign(groups, 1);
    stats.resize(groups);
    keep_flown(groups);
  }
  // Appends the clusters of `members` (sorted by (root, body)) with their candidates.
  void add(const std::vector<std::pair<std::uint32_t, std::uint32_t>> &members,
           const std::vector<std::pair<std::uint32_t, Edge>> &candidates,
           std::vector<std::uint32_t> &group_of) {
    std::size_t c = 0;
    for (std::size_t k = 0; k < members.size();) {
      const std::uint32_t r = members[k].first;
      const auto g = static_cast<std::uint32_t>(alive.size());
      for (; k < members.size() && members[k].first == r; ++k) {
        bodies.push_back(members[k].second);
        group_of[members[k].second] = g;
      }
      body_start.push_back(bodies.size());
      while (c < candidates.size() && candidates[c].first < r) ++c;
      char live = 0;
      for (; c < candidates.size() && candidates[c].first == r; ++c) {
        cands.push_back(candidates[c].second);
        live |= candidates[c].second.live;
      }
      cand_start.push_back(cands.size());
      alive.push_back(1);
      eventful.push_back(live);
    }
    stats.resize(alive.size());
    keep_flown(alive.size());
  }

 private:
  // Room for the flown bodies of `groups` clusters. Never shrunk: a cluster's list keeps its
  // storage from step to step (solve clears it before the pass), where a shrink and a regrowth
  // would free it and allocate it again; a list past the step's clusters is never read.
  void keep_flown(std::size_t groups) {
    if (flown.size() < groups) flown.resize(groups);
  }
  std::vector<std::size_t> scratch_;  // first(): the clusters' sizes, then their fill points
};

// The clusters' storage, kept from step to step (first() resets it): a step then allocates
// nothing for its clusters, nor for their flown bodies.
Partition &step_partition() {
  thread_local Partition pt;
  return pt;
}

// Below this many eventful clusters a step solves them on one thread: a parallel region costs
// more than a few small clusters.
constexpr long kParallelClusters = 32;
// Below this many clusters, their overrun check (reaches) runs on one thread: a parallel region
// costs more than the check of a few hundred clusters (the everyday nematic's); the paper
// scene's thousands gain.
constexpr long kParallelChecks = 1024;

// The state of cluster g's bodies asked from memory ahead of its pass: each body's twelve
// fields, its id and its growth live in fourteen arrays, so a cluster's first reads are a dozen
// cache misses per body.
void prefetch_bodies(const Particles &p, const Partition &pt, std::size_t g) {
  for (std::size_t k = pt.body_start[g]; k < pt.body_start[g + 1]; ++k) {
    const std::uint32_t b = pt.bodies[k];
    for (BodyField f : kStateFields) __builtin_prefetch(&(p.*f)[b]);
    __builtin_prefetch(&p.id[b]);
    __builtin_prefetch(&p.grow[b]);
  }
}

// How many eventful clusters ahead their bodies are asked for: most clusters of a step are not
// eventful (hard spheres at packing fraction 0.45: ~950 of ~3900), and a pass over a small one
// takes about a miss's time.
constexpr long kPrefetchClusters = 4;

// Solves the eventful clusters of [from, partition.count()), threads taking whole clusters.
void solve(const Context &cx, Partition &pt, std::size_t from) {
  thread_local std::vector<std::uint32_t> eventful_clusters;
  std::vector<std::uint32_t> &todo = eventful_clusters;  // the team's, through a reference
  todo.clear();
  for (std::size_t g = from; g < pt.count(); ++g)
    if (pt.eventful[g]) todo.push_back(static_cast<std::uint32_t>(g));
  const auto n = static_cast<long>(todo.size());
#pragma omp parallel if (n > kParallelClusters)
  {
    ClusterPass pass(cx);
#pragma omp for schedule(dynamic, 4)
    for (long k = 0; k < n; ++k) {
      if (k + kPrefetchClusters < n) prefetch_bodies(cx.p, pt, todo[k + kPrefetchClusters]);
      const std::size_t g = todo[k];
      pt.flown[g].clear();
      pt.stats[g] =
          pass.run(static_cast<std::uint32_t>(g), pt.bodies.data() + pt.body_start[g],
                   pt.body_start[g + 1] - pt.body_start[g], pt.cands.data() + pt.cand_start[g],
                   pt.cand_start[g + 1] - pt.cand_start[g], pt.flown[g]);
    }
  }
}

// Such pairs from the flown bodies of the live clusters [from, count): their clusters are
// solved together. The clusters before `from` were checked when they were solved, and a pair
// between one of them and a cluster solved since would be found from the new cluster's side
// (the test is symmetric, and only the new cluster's overruns changed). `overrun` holds every
// live cluster's overruns. Threads take clusters where there are many (a parallel region costs
// more than the check of a few hundred); the pairs come out sorted and distinct, so their
// order does not depend on the threads.
std::vector<BodyPair> reaches(const Context &cx, const Partition &pt,
                              const std::vector<double> &overrun, std::size_t from) {
  const auto n = static_cast<long>(pt.count() - from);
  thread_local std::vector<std::vector<BodyPair>> found;
  std::vector<std::vector<BodyPair>> &shared = found;  // the team's, through a reference
  shared.resize(static_cast<std::size_t>(omp_get_max_threads()));
  for (std::vector<BodyPair> &f : shared) f.clear();
#pragma omp parallel if (n > kParallelChecks)
  {
    std::vector<Overrunner<std::uint32_t>> mine;
#pragma omp for schedule(dynamic, 16) nowait
    for (long k = 0; k < n; ++k) {
      const auto g = static_cast<std::uint32_t>(from + static_cast<std::size_t>(k));
      if (!pt.alive[g] || !pt.eventful[g]) continue;
      for (const FlownBody &f : pt.flown[g])
        if (f.overrun > 0.0) mine.push_back({f.body, g});
    }
    OverrunCheck<std::uint32_t>(cx.p, cx.box, cx.inverse, cx.shape, cx.list, overrun,
                                cx.group_of.data(),
                                shared[static_cast<std::size_t>(omp_get_thread_num())])
        .run(mine);
  }
  std::vector<BodyPair> out;
  for (const std::vector<BodyPair> &f : shared) out.insert(out.end(), f.begin(), f.end());
  distinct_pairs(out);
  return out;
}

// Joins the clusters the pairs reach across, and appends the joined clusters (dead ones
// marked) for solving; bodies of no cluster come in.
void regroup(const std::vector<BodyPair> &joins, ExactScratch &scratch, Partition &pt) {
  std::vector<std::uint32_t> touched;  // bodies whose cluster is joined
  std::vector<Edge> taken;             // their candidates (a body that comes in has none)
  const auto take = [&](std::uint32_t b) {
    if (scratch.parent[b] == kNone) {
      scratch.parent[b] = b;
      touched.push_back(b);
      return;
    }
    const std::uint32_t g = scratch.label[b];
    if (g == kNone || !pt.alive[g]) return;  // came in or was taken already
    pt.alive[g] = 0;
    if (pt.eventful[g])  // solved again: its bodies' overruns are the new pass's
      for (const FlownBody &f : pt.flown[g]) scratch.overrun[f.body] = 0.0;
    touched.insert(touched.end(), pt.bodies.begin() + static_cast<long>(pt.body_start[g]),
                   pt.bodies.begin() + static_cast<long>(pt.body_start[g + 1]));
    taken.insert(taken.end(), pt.cands.begin() + static_cast<long>(pt.cand_start[g]),
                 pt.cands.begin() + static_cast<long>(pt.cand_start[g + 1]));
  };
  for (const auto &[a, b] : joins) {
    take(a);
    take(b);
    join_sets(scratch.parent, a, b);
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> members;
  for (const std::uint32_t b : touched) members.emplace_back(set_root(scratch.parent, b), b);
  std::sort(members.begin(), members.end());
  // By new cluster, and within one in the candidates' canonical order: their places in the
  // step's one array of candidates, which is in that order.
  std::vector<std::pair<std::uint32_t, Edge>> cands;
  for (const Edge &c : taken) cands.emplace_back(set_root(scratch.parent, c.i), c);
  std::sort(cands.begin(), cands.end(), [](const auto &x, const auto &y) {
    return x.first != y.first ? x.first < y.first : x.second.at < y.second.at;
  });
  pt.add(members, cands, scratch.label);
}

// The clusters of the candidates joined by `joins`: scratch's union-find over the bodies in
// them, and the partition (`screened`: Partition::first).
void first_partition(const NeighborList &list, const std::vector<Candidate> &candidates,
                     const std::vector<BodyPair> &joins, bool screened, ExactScratch &scratch,
                     Partition &pt) {
  const std::size_t n = list.active;
  scratch.parent.resize(n, kNone);
  scratch.label.resize(n, kNone);
  scratch.overrun.resize(n, 0.0);
  // The bodies taken, ascending: a bit each, read back word by word.
  std::vector<std::uint64_t> &bits = scratch.involved_bits;
  bits.assign((n + 63) / 64, 0);
  const auto take = [&](std::uint32_t b) {
    if (scratch.parent[b] != kNone) return;
    scratch.parent[b] = b;
    bits[b / 64] |= std::uint64_t{1} << (b % 64);
  };
  for (const Candidate &c : candidates) take(c.i), take(c.j);
  for (const auto &[a, b] : joins) take(a), take(b);
  std::vector<std::uint32_t> &involved = scratch.involved;
  involved.clear();
  for (std::size_t w = 0; w < bits.size(); ++w)
    for (std::uint64_t word = bits[w]; word != 0; word &= word - 1)
      involved.push_back(static_cast<std::uint32_t>(64 * w + std::countr_zero(word)));
  for (const Candidate &c : candidates) join_sets(scratch.parent, c.i, c.j);
  for (const auto &[a, b] : joins) join_sets(scratch.parent, a, b);
  pt.first(scratch.parent, involved, candidates, screened, scratch.label);
}

// The final partition's physics into `stats` (the counts of work are the passes' own, including
// those a join discarded), its flown bodies into `flown`; the scratch cleared for the next step.
void finish(const Partition &pt, ExactStats &stats, ExactScratch &scratch,
            std::vector<FlownBody> &flown) {
  stats.collisions = stats.fallbacks = 0;
  stats.virial = ExactSum();
  for (std::size_t g = 0; g < pt.count(); ++g) {
    if (!pt.alive[g]) continue;
    ++stats.clusters;
    stats.largest_cluster = std::max(
        stats.largest_cluster, static_cast<long long>(pt.body_start[g + 1] - pt.body_start[g]));
    if (!pt.eventful[g]) continue;
    stats.collisions += pt.stats[g].collisions;
    stats.fallbacks += pt.stats[g].fallbacks;
    stats.virial += pt.stats[g].virial;
    flown.insert(flown.end(), pt.flown[g].begin(), pt.flown[g].end());
    for (const FlownBody &f : pt.flown[g]) scratch.overrun[f.body] = 0.0;
  }
  for (const std::uint32_t b : pt.bodies) scratch.parent[b] = scratch.label[b] = kNone;
}

}  // namespace

void solve_by_clusters(const Particles &p, const Box &box, const Shape &shape,
                       const NeighborList &list, const std::vector<Candidate> &candidates,
                       const std::vector<BodyPair> &joins, double dt, const ExactSettings &settings,
                       bool regrow, ExactScratch &scratch, ExactStats &stats,
                       std::vector<FlownBody> &flown) {
  Partition &pt = step_partition();
  first_partition(list, candidates, joins, screened(settings), scratch, pt);
  const Context cx{p,  box,      box.inverse_length(),  shape, list, scratch.label,
                   dt, settings, scratch.overrun.data()};
  for (std::size_t from = 0;;) {
    solve(cx, pt, from);
    for (std::size_t g = from; g < pt.count(); ++g)
      if (pt.eventful[g]) stats += pt.stats[g];
    if (!regrow) break;
    // The live clusters' overruns are in scratch.overrun (their passes wrote them, regroup
    // cleared those of the clusters it joined): finish clears them.
    const std::vector<BodyPair> found = reaches(cx, pt, scratch.overrun, from);
    if (found.empty()) break;
    stats.regrown += static_cast<long long>(found.size());
    from = pt.count();
    regroup(found, scratch, pt);
  }
  finish(pt, stats, scratch, flown);
}

}  // namespace hardrod::exact_events
