// The exact method's detection at the step's start (kernels/exact/step_candidates.hpp): the
// batched narrow phase and its screens give the scalar arithmetic's bits, the screens' proofs
// hold along the free flights, and the watches find the spares of an overrun allowance.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <utility>

#include "kernels/contact_detection.hpp"
#include "kernels/exact/contact_time.hpp"
#include "kernels/exact/step_candidates.hpp"
#include "kernels/free_flight.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/segment_geometry.hpp"
#include "tests/random_gas.hpp"
#include "tests/thread_count_guard.hpp"

namespace hardrod {
namespace {

using testing::random_gas;

// A random gas in `box` (rods of the given length, aligned or not, or spheres: 400 or 2000
// bodies) listed with a skin of 0.8, its motion constants set for a step of `dt`, and every
// listed pair due.
struct DueGas {
  Shape shape;
  Particles p;
  NeighborList list;
};
DueGas due_gas(const Box &box, double length, bool aligned, std::uint64_t seed, double dt) {
  DueGas g;
  g.shape.length = length;
  const std::size_t n = length > 0.0 ? 400 : 2000;
  g.p = random_gas(n, box, seed, aligned);
  g.list.skin = 0.8;
  build_neighbor_list(g.list, g.p, n, box, g.shape);
  refresh_motion(g.p, n, g.shape, 0.5 * dt);
  for (std::size_t i = 0; i < n; ++i) g.p.motion_bound[i] = g.list.skin;
  return g;
}

// The batched narrow phase (the due pairs measured in vector lanes, the candidates screened
// there) gives the bits of the scalar arithmetic: every listed pair's renewed slack is
// (moved - reach) + (d - D) - margin with d from segment_closest, every candidate's depth is
// D - d, and its `apart` mark is apart_in_flight's, for rods (aligned and not) and spheres,
// with enough due pairs for several batches and a partial one. With an overrun allowance A,
// the pairs with d < D + reach + 2 A come too, those beyond the reach as spares.
TEST(StepCandidates, BatchedNarrowPhaseGivesTheScalarBits) {
  Box box;
  box.length = {14.0, 15.0, 16.0};
  for (const double length : {5.0, 0.0})
    for (const bool aligned : {true, false})
      for (const double allowance : {0.0, 0.02}) {
        SCOPED_TRACE("L = " + std::to_string(length) + (aligned ? ", aligned" : ", random") +
                     ", allowance " + std::to_string(allowance));
        const double dt = 0.02;
        DueGas gas = due_gas(box, length, aligned, 11, dt);
        const Shape &shape = gas.shape;
        Particles &p = gas.p;
        NeighborList &list = gas.list;
        const std::vector<ListedPair> before = list.pairs;
        const StepAhead ahead{p.grow.data(), dt, true, allowance};
        std::vector<Candidate> candidates;
        const DetectionStats stats =
            detect_candidates_all_pairs(p, box, shape, list, candidates, ahead);
        ASSERT_EQ(stats.narrow_phase_tests, static_cast<long long>(list.pair_count()));
        ASSERT_GT(list.pair_count(), 600u) << "several batches of 256";
        const double h = shape.half_length(), D = shape.diameter;
        std::map<std::pair<std::int64_t, std::int64_t>, const Candidate *> by_ids;
        for (const Candidate &c : candidates) by_ids[{c.id_i, c.id_j}] = &c;
        std::size_t found = 0, apart = 0, spares = 0;
        for (std::size_t k = 0; k < list.pair_count(); ++k) {
          const ListedPair &pair = list.pairs[k];
          const std::uint32_t i = p.id[pair.first] < p.id[pair.second] ? pair.first : pair.second;
          const std::uint32_t j = i == pair.first ? pair.second : pair.first;
          const Vec3 r = box.minimum_image(p.position(j) - p.position(i), box.inverse_length());
          const SegmentClosest sc = segment_closest(r, p.axis(i), h, p.axis(j), h);
          const double d = std::sqrt(sc.dist2);
          const double reach = 2.0 * (p.grow[pair.first] + p.grow[pair.second]);
          const double moved = p.motion_bound[pair.first] + p.motion_bound[pair.second];
          ASSERT_EQ(pair.recheck_at, slack_below((moved - reach) + (d - D) - kDistanceSafetyMargin))
              << "pair " << k;
          const auto it = by_ids.find({p.id[i], p.id[j]});
          ASSERT_EQ(it != by_ids.end(), d < D + (reach + 2.0 * allowance)) << "pair " << k;
          if (it == by_ids.end()) continue;
          ++found;
          EXPECT_EQ(it->second->depth, D - d);
          ASSERT_EQ(it->second->spare, !(d < D + reach)) << "pair " << k;
          if (it->second->spare) {
            EXPECT_TRUE(it->second->apart) << "pair " << k;
            ++spares;
            continue;
          }
          const Flight fi{p.position(i), p.axis(i), p.velocity(i), p.angular_velocity(i), 0.0};
          const Flight fj{p.position(i) + r, p.axis(j), p.velocity(j), p.angular_velocity(j), 0.0};
          const bool proven =
              apart_in_flight(fi, fj, r, h > 0.0 ? sc : SegmentClosest{}, h, D, dt, kApartMargin);
          EXPECT_EQ(it->second->apart, proven) << "pair " << k;
          apart += proven;
        }
        EXPECT_EQ(found, candidates.size());
        EXPECT_GT(found - spares, 20u) << "the test must exercise candidates";
        EXPECT_GT(apart, 5u) << "and candidates proven apart";
        EXPECT_LT(apart, found - spares) << "and candidates not proven apart";
        if (allowance > 0.0) {
          EXPECT_GT(spares, 5u) << "and spares";
        }
        EXPECT_NE(before.front().recheck_at, list.pairs.front().recheck_at);
      }
}

// Candidate::proven, the screens' (and a spare's) proof that the one queue keeps a pair apart
// with (exact_queue.cpp), is a lower bound of the surface gap less kApartMargin at every time of
// the step along the two free flights (sampled finely), for rods (aligned and not) and spheres;
// and it is not loose: the samples come within a few per cent of the bound's least value for
// some pairs (a bound taken at the step's start alone would not hold).
TEST(StepCandidates, ProvenGapsHoldAlongTheFreeFlights) {
  Box box;
  box.length = {14.0, 15.0, 16.0};
  for (const double length : {5.0, 0.0})
    for (const bool aligned : {true, false}) {
      SCOPED_TRACE("L = " + std::to_string(length) + (aligned ? ", aligned" : ", random"));
      const double dt = 0.02;
      DueGas gas = due_gas(box, length, aligned, 13, dt);
      const Shape &shape = gas.shape;
      const Particles &p = gas.p;
      std::vector<Candidate> candidates;
      detect_candidates_all_pairs(p, box, shape, gas.list, candidates,
                                  StepAhead{p.grow.data(), dt, true, 0.02});
      const double h = shape.half_length(), D = shape.diameter;
      std::size_t proofs = 0, tight = 0, spares = 0;
      for (const Candidate &c : candidates) {
        EXPECT_GE(c.proven, 0.0);
        EXPECT_TRUE(c.proven == 0.0 || c.apart) << "a proof only where apart";
        if (!(c.proven > 0.0)) continue;
        ++proofs;
        spares += c.spare;
        const Vec3 r = box.minimum_image(p.position(c.j) - p.position(c.i), box.inverse_length());
        const Flight fi{p.position(c.i), p.axis(c.i), p.velocity(c.i), p.angular_velocity(c.i),
                        0.0};
        const Flight fj{p.position(c.i) + r, p.axis(c.j), p.velocity(c.j), p.angular_velocity(c.j),
                        0.0};
        double least = std::numeric_limits<double>::infinity();
        for (int k = 0; k <= 400; ++k) {
          const double t = dt * k / 400.0;
          const SegmentClosest sc =
              segment_closest(fj.position(t) - fi.position(t), fi.axis(t), h, fj.axis(t), h);
          least = std::min(least, std::sqrt(sc.dist2) - D - kApartMargin);
        }
        ASSERT_GE(least, c.proven - 1e-12) << "bodies " << c.id_i << ", " << c.id_j;
        tight += least < 1.05 * c.proven;
      }
      EXPECT_GT(proofs, 20u) << "the test must exercise proofs";
      EXPECT_GT(spares, 0u) << "of spares too";
      EXPECT_GT(tight, 0u) << "and proofs close to the gap";
    }
}

// The exact method's detection with an overrun allowance (StepAhead::allowance) finds through
// the watches the candidates and spares a pass over every pair finds: a body is flagged once
// its bound plus the allowance reaches its watch, and a pair is due once its two bounds plus
// twice the allowance reach its slack. Rods fly through each other (no collisions) at a step
// at which several bodies rebuild the list.
TEST(StepCandidates, WatchesFindTheSparesOfAnAllowance) {
  const Shape shape{.length = 5.0};
  Box box;
  box.length = {18.0, 20.0, 19.0};
  Particles p = random_gas(150, box, 5, true);
  const std::size_t n = p.size();
  const double dt = 0.004, allowance = 0.5 * dt;
  NeighborList list;
  list.skin = 0.6;
  list.watched_share = 1;  // a list this small would soon switch to the full pass
  refresh_motion(p, n, shape, 0.5 * dt);
  std::size_t candidates = 0, spares = 0;
  for (int step = 0; step < 300; ++step) {
    if (neighbor_list_expired(list, grow_bounds(p, n), n)) {
      build_neighbor_list(list, p, n, box, shape);
      grow_bounds(p, n);
    }
    NeighborList every = list;  // the same list, filtered by a pass over every pair
    std::vector<Candidate> watched, all;
    const StepAhead ahead{p.grow.data(), dt, true, allowance};
    ASSERT_TRUE(detect_candidates(p, box, shape, list, watched, ahead).watched) << "step " << step;
    detect_candidates_all_pairs(p, box, shape, every, all, ahead);
    ASSERT_EQ(watched.size(), all.size()) << "step " << step;
    for (std::size_t k = 0; k < all.size(); ++k) {
      ASSERT_EQ(watched[k].id_i, all[k].id_i) << "step " << step;
      ASSERT_EQ(watched[k].id_j, all[k].id_j) << "step " << step;
      ASSERT_EQ(watched[k].spare, all[k].spare) << "step " << step;
      ASSERT_EQ(watched[k].apart, all[k].apart) << "step " << step;
      spares += all[k].spare;
    }
    candidates += all.size();
    fly_step(p, n, shape, 0.5 * dt);
  }
  EXPECT_GT(list.builds, 2);
  EXPECT_GT(spares, 20u) << "the test must exercise spares";
  EXPECT_GT(candidates, spares + 20) << "and candidates";
}

}  // namespace
}  // namespace hardrod
