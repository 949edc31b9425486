// The overrun check of the exact method's collisions (exact_collisions.hpp), internal to
// kernels/exact/: the listed pairs from bodies whose velocity changed (and may have carried them
// beyond their free flight's bound) to bodies of other clusters that could have touched within
// the step. The clusters' passes (exact_clusters.cpp) and the ranks' rounds (overrun_reaches,
// exact_collisions.cpp) run it.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/exact/exact_events.hpp"

namespace hardrod::exact_events {

// A flown body with an overrun, and the label of its cluster.
template <class Label>
struct Overrunner {
  std::uint32_t body;
  Label label;
};

// The listed pairs from flown bodies (with overrun) to bodies of other clusters (labels differ;
// bodies of no cluster share a label no flown body has) that could have touched in the step:
// first the slack with the real bounds, then the distance at the start against the two bodies'
// reaches; appended to `out`. Every load here is scattered through memory (a miss each at
// N = 32768: the bodies' pair ranges, partners, labels, the pairs' records, the partners'
// bounds), so each is asked for ahead of its use, a few bodies or a chunk of pairs before, and
// they are in flight together instead of one after another.
template <class Label>
class OverrunCheck {
 public:
  OverrunCheck(const Particles &p, const Box &box, const Vec3 &inverse, const Shape &shape,
               const NeighborList &list, const std::vector<double> &overrun, const Label *label,
               std::vector<BodyPair> &out)
      : p_(p),
        box_(box),
        inverse_(inverse),
        shape_(shape),
        list_(list),
        overrun_(overrun),
        label_(label),
        out_(out) {}

  void run(const std::vector<Overrunner<Label>> &bodies) {
    const std::uint32_t *start = list_.pairs_start.data(), *end = list_.pairs_end.data(),
                        *partner = list_.pair_partner.data();
    const std::size_t n = bodies.size();
    for (std::size_t k = 0; k < n; ++k) {
      if (k + 16 < n) __builtin_prefetch(&start[bodies[k + 16].body]);
      if (k + 8 < n) {
        const std::uint32_t q = start[bodies[k + 8].body];
        __builtin_prefetch(&partner[q]);
        __builtin_prefetch(&list_.pair_index[q]);
      }
      if (k + 4 < n) {
        const std::uint32_t b = bodies[k + 4].body;
        for (std::uint32_t q = start[b]; q < end[b]; ++q) __builtin_prefetch(&label_[partner[q]]);
      }
      add(bodies[k]);
    }
    for (std::size_t k = 0; k < count_; ++k) check(queued_[k]);
    count_ = 0;
  }

 private:
  static constexpr std::size_t kChunk = 32;
  struct Queued {
    std::uint32_t body, other, pair;
  };

  // The pairs of f with a partner in another cluster, queued; their records and the partners'
  // bounds asked for.
  void add(const Overrunner<Label> &f) {
    for (std::uint32_t q = list_.pairs_start[f.body]; q < list_.pairs_end[f.body]; ++q) {
      const std::uint32_t other = list_.pair_partner[q];
      if (label_[other] == f.label) continue;
      const std::uint32_t pair = list_.pair_index[q];
      __builtin_prefetch(&list_.pairs[pair]);
      __builtin_prefetch(&p_.motion_bound[other]);
      __builtin_prefetch(&overrun_[other]);
      queued_[count_++] = {f.body, other, pair};
      if (count_ == kChunk) {
        for (const Queued &at : queued_) check(at);
        count_ = 0;
      }
    }
  }

  void check(const Queued &at) const {
    if (overrun_could_touch(p_, box_, inverse_, shape_, list_.pairs[at.pair], at.body,
                            overrun_[at.body], at.other, overrun_[at.other]))
      out_.emplace_back(at.body, at.other);
  }

  const Particles &p_;
  const Box &box_;
  const Vec3 &inverse_;
  const Shape &shape_;
  const NeighborList &list_;
  const std::vector<double> &overrun_;
  const Label *label_;
  std::vector<BodyPair> &out_;
  Queued queued_[kChunk];
  std::size_t count_ = 0;
};

// Each pair once, the lower index first.
inline void distinct_pairs(std::vector<BodyPair> &pairs) {
  for (auto &[a, b] : pairs)
    if (a > b) std::swap(a, b);
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
}

}  // namespace hardrod::exact_events
