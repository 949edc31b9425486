// The broad phase (cell list + Verlet list with lazy re-checks) must find exactly the
// contacts an O(N^2) loop over all pairs finds, step after step, for rods and spheres,
// whatever the skin and the thread count.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <type_traits>
#include <utility>

#include "kernels/cell_list.hpp"
#include "kernels/contact_detection.hpp"
#include "kernels/exact/step_candidates.hpp"
#include "kernels/free_flight.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/segment_geometry.hpp"
#include "tests/random_gas.hpp"
#include "tests/thread_count_guard.hpp"

namespace hardrod {
namespace {

using testing::random_gas;

using PairSet = std::set<std::pair<std::int64_t, std::int64_t>>;

PairSet brute_force(const Particles &p, const Box &box, const Shape &shape) {
  PairSet out;
  const double h = shape.half_length();
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      const Vec3 r = box.minimum_image(p.position(j) - p.position(i));
      const auto sc = segment_closest(r, p.axis(i), h, p.axis(j), h);
      if (std::sqrt(sc.dist2) < shape.diameter)
        out.insert({std::min(p.id[i], p.id[j]), std::max(p.id[i], p.id[j])});
    }
  return out;
}

PairSet as_set(const std::vector<Contact> &contacts) {
  PairSet out;
  for (const auto &c : contacts) out.insert({c.id_i, c.id_j});
  return out;
}

struct Case {
  double length;
  double skin;
  bool aligned;
  int threads;
};

class DetectionMatchesBruteForce : public ::testing::TestWithParam<Case> {};

TEST_P(DetectionMatchesBruteForce, OverManySteps) {
  const Case c = GetParam();
  Shape shape;
  shape.length = c.length;
  Box box;
  box.length = {2.2 * (c.length + 1.0) + 3.0, 2.5 * (c.length + 1.0) + 2.0,
                2.1 * (c.length + 1.0) + 4.0};
  const std::size_t n = static_cast<std::size_t>(0.25 * box.volume() / shape.volume());
  omp_set_num_threads(c.threads);
  // With the watches kept through every step, and with the switch to the full pass.
  for (const long share : {1L, kWatchedShare}) {
    SCOPED_TRACE("watched_share " + std::to_string(share));
    Particles p = random_gas(n, box, 42 + static_cast<int>(c.length), c.aligned);
    NeighborList list;
    list.skin = c.skin;
    list.watched_share = share;
    std::vector<Contact> contacts, reference;
    long long total_contacts = 0, tests = 0, watched_steps = 0;
    NeighborList all;  // the same list, filtered by a pass over every pair
    for (int step = 0; step < 60; ++step) {
      // Large moves: many rebuilds and re-checks; centres leave the box (never folded).
      half_step(p, n, shape, 0.01);
      if (neighbor_list_expired(list, largest_motion_bound(p, n), n)) {
        build_neighbor_list(list, p, n, box, shape);
        all = list;
      }
      const DetectionStats watched = detect_contacts(p, box, shape, list, contacts);
      watched_steps += list.watching;
      ASSERT_TRUE(std::is_sorted(contacts.begin(), contacts.end(), canonical_less));
      const PairSet expected = brute_force(p, box, shape);
      ASSERT_EQ(as_set(contacts), expected) << "step " << step;
      total_contacts += static_cast<long long>(contacts.size());
      // The watches measure exactly the pairs the full pass measures, to the bit.
      const DetectionStats full = detect_contacts_all_pairs(p, box, shape, all, reference);
      ASSERT_EQ(watched.narrow_phase_tests, full.narrow_phase_tests) << "step " << step;
      for (std::size_t k = 0; k < list.pair_count(); ++k)
        ASSERT_EQ(list.pairs[k].recheck_at, all.pairs[k].recheck_at) << "step " << step;
      ASSERT_EQ(as_set(reference), expected) << "step " << step;
      tests += watched.narrow_phase_tests;
    }
    EXPECT_GT(total_contacts, 20) << "the test must exercise real contacts";
    EXPECT_GT(list.builds, 1) << "the test must exercise list rebuilds";
    EXPECT_GT(tests, 100) << "the test must exercise re-checks";
    if (share == 1) {
      EXPECT_EQ(watched_steps, 60);
    }
  }
  omp_set_num_threads(1);
}

INSTANTIATE_TEST_SUITE_P(Shapes, DetectionMatchesBruteForce,
                         ::testing::Values(Case{5.0, 0.3, true, 1}, Case{5.0, 0.3, false, 2},
                                           Case{5.0, 0.05, true, 2}, Case{0.0, 0.3, false, 1},
                                           Case{0.0, 0.1, false, 2}, Case{1.0, 0.5, false, 2}),
                         [](const ::testing::TestParamInfo<Case> &info) {
                           const Case &c = info.param;
                           return "L" + std::to_string(static_cast<int>(c.length)) + "_skin" +
                                  std::to_string(static_cast<int>(c.skin * 100)) +
                                  (c.aligned ? "_aligned" : "_random") + "_threads" +
                                  std::to_string(c.threads);
                         });

// Watches that give up at the first step after a build (every body reached its watch at once,
// as under the exact method's whole-flight bounds) are not armed for the next kUnarmedBuilds
// builds, then tried again; watches that served a step before giving up are armed at the next
// build. The contacts are those of the full pass either way.
TEST(Detection, WatchesThatGiveUpAtOnceSkipTheNextBuilds) {
  Shape shape;
  shape.length = 0.0;
  Box box;
  box.length = {12.0, 12.0, 12.0};
  // Spheres on a cubic lattice of spacing 1.2: no overlaps, each pair's slack 0.2.
  const std::size_t side = 10, n = side * side * side;
  Particles p;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(i);
    p.set_position(i,
                   {1.2 * static_cast<double>(i % side), 1.2 * static_cast<double>(i / side % side),
                    1.2 * static_cast<double>(i / (side * side))});
    p.set_axis(i, {0.0, 0.0, 1.0});
  }
  NeighborList list;
  list.skin = 0.4;
  std::vector<Contact> contacts;
  const auto flag_all = [&] {  // bounds past every watch, the list not expired
    for (std::size_t i = 0; i < n; ++i) p.motion_bound[i] = 0.15;
  };
  build_neighbor_list(list, p, n, box, shape);
  ASSERT_TRUE(list.watching);
  flag_all();
  detect_contacts(p, box, shape, list, contacts);
  EXPECT_TRUE(contacts.empty());
  ASSERT_FALSE(list.watching) << "the case must make the watches give up";
  EXPECT_EQ(list.unarmed_builds, kUnarmedBuilds);
  for (int b = 0; b < kUnarmedBuilds; ++b) {
    build_neighbor_list(list, p, n, box, shape);
    EXPECT_FALSE(list.watching) << "build " << b;
    flag_all();
    detect_contacts(p, box, shape, list, contacts);
    EXPECT_TRUE(contacts.empty()) << "build " << b;
  }
  build_neighbor_list(list, p, n, box, shape);
  EXPECT_TRUE(list.watching) << "tried again";
  // A step through the watches (bounds zero), then giving up: the next build arms them.
  detect_contacts(p, box, shape, list, contacts);
  EXPECT_TRUE(list.watching);
  flag_all();
  detect_contacts(p, box, shape, list, contacts);
  EXPECT_FALSE(list.watching);
  EXPECT_EQ(list.unarmed_builds, 0);
  build_neighbor_list(list, p, n, box, shape);
  EXPECT_TRUE(list.watching);
}

// The contacts come in canonical order by whichever sort the detection takes: the radix sort
// of the packed ids with 8-bit digits (from 64 contacts) and with 11-bit digits (from 4096),
// the comparison of packed ids (fewer), and the comparison of the pairs (ids past 2^31), on one
// and two threads.
TEST(Detection, ContactsInCanonicalOrderAtAnyCount) {
  Shape shape;
  shape.length = 0.0;
  Box box;
  box.length = {12.0, 13.0, 14.0};
  struct Path {
    std::size_t bodies, fewest, most;  // contacts expected in [fewest, most)
  };
  for (const Path path : {Path{150, 5, 64}, Path{600, 64, 4096}, Path{6000, 4096, 1u << 30}})
    for (const std::int64_t offset : {std::int64_t{0}, std::int64_t{3} << 31})
      for (const int threads : {1, 2}) {
        const std::size_t n = path.bodies;
        SCOPED_TRACE(std::to_string(n) + " bodies, ids from " + std::to_string(offset) + ", " +
                     std::to_string(threads) + " threads");
        omp_set_num_threads(threads);
        Particles p = random_gas(n, box, 7, false);
        for (std::size_t i = 0; i < n; ++i) p.id[i] += offset;
        NeighborList list;
        build_neighbor_list(list, p, n, box, shape);
        std::vector<Contact> contacts;
        detect_contacts_all_pairs(p, box, shape, list, contacts);
        EXPECT_EQ(as_set(contacts), brute_force(p, box, shape));
        for (std::size_t k = 1; k < contacts.size(); ++k)
          ASSERT_TRUE(canonical_less(contacts[k - 1], contacts[k])) << "contact " << k;
        EXPECT_GE(contacts.size(), path.fewest) << "the sort path must be exercised";
        EXPECT_LT(contacts.size(), path.most) << "the sort path must be exercised";
      }
  omp_set_num_threads(1);
}

// The watches hold what they promise: after any step, every listed pair's two bounds are
// below its slack unless one of its bodies has reached its watch, and each watch is at
// most the body's allowance in each of its pairs, which sum to less than the slack. And
// they pay: the pairs read are a small part of the list.
void check_watches(double scale, std::size_t bodies, int threads, int steps) {
  Shape shape;
  Box box;
  box.length = {18 * scale, 20 * scale, 19 * scale};
  // A gas without overlaps (bodies of an overlapping pair dropped): a body in contact is
  // flagged at every step, as the pass over all pairs measures its pair at every step.
  Particles gas = random_gas(bodies, box, 7, true);
  std::set<std::int64_t> dropped;
  for (const auto &[a, b] : brute_force(gas, box, shape)) dropped.insert({a, b});
  Particles p;
  for (std::size_t i = 0; i < gas.size(); ++i)
    if (!dropped.count(gas.id[i])) {
      const std::size_t k = p.size();
      p.resize(k + 1);
      p.id[k] = gas.id[i];
      p.set_position(k, gas.position(i));
      p.set_axis(k, gas.axis(i));
      p.set_velocity(k, gas.velocity(i));
      p.set_angular_velocity(k, gas.angular_velocity(i));
    }
  const std::size_t n = p.size();
  ASSERT_GT(n, bodies / 3);
  omp_set_num_threads(threads);
  NeighborList list;
  list.skin = 0.4;
  list.watched_share = 1;  // a list this small would soon switch to the full pass
  std::vector<Contact> contacts;
  long long read = 0, listed = 0;
  for (int step = 0; step < steps; ++step) {
    half_step(p, n, shape, 0.0001);
    if (neighbor_list_expired(list, largest_motion_bound(p, n), n))
      build_neighbor_list(list, p, n, box, shape);
    detect_contacts(p, box, shape, list, contacts);
    // Bodies that touch turn back (each once per step), so that contacts stay brief as
    // in a run; a pair in contact is measured at every step.
    std::set<std::uint32_t> turned;
    for (const Contact &c : contacts)
      for (const std::uint32_t b : {c.i, c.j})
        if (turned.insert(b).second) {
          p.set_velocity(b, -1.0 * p.velocity(b));
          p.set_angular_velocity(b, -1.0 * p.angular_velocity(b));
        }
    ASSERT_TRUE(list.watching) << "step " << step;
    for (std::size_t i = 0; i < n; ++i)
      if (list.flagged[i]) read += list.pairs_start[i + 1] - list.pairs_start[i];
    listed += static_cast<long long>(list.pair_count());
    for (std::size_t k = 0; k < list.pair_count(); ++k) {
      const ListedPair &pair = list.pairs[k];
      ASSERT_LE(list.watch[pair.first], pair.allowance_first) << "step " << step << " pair " << k;
      ASSERT_LE(list.watch[pair.second], pair.second_allowance())
          << "step " << step << " pair " << k;
      ASSERT_LT(pair.allowance_first + pair.second_allowance(), pair.recheck_at);
    }
  }
  EXPECT_GT(list.builds, 1);
  EXPECT_GT(read, 0);
  EXPECT_LT(read, listed / 4) << "pair ends read against pairs listed, over all steps";
  omp_set_num_threads(1);
}

TEST(Detection, WatchesCoverEveryPair) { check_watches(1.0, 100, 1, 3000); }

// Steps that pass over every pair read only the list's near pairs while those hold
// (NearPairs): they must find what the pass over every pair finds, the same pairs measured
// (so the same slacks after), for contacts and for the exact method's candidates with spares,
// rods and spheres, one thread and two. Every 20 steps a seventh of the bodies is kicked to
// 2.5 times its speed (for 10 steps), so the near pairs must be given up before their reach is
// used. Each fails if
// near_holds forgets the bounds' growth, or the factor 2 on it (both bodies grow).
template <class Found>
void check_near_pairs(double length, std::size_t bodies, int threads, int steps) {
  testing::ThreadCountGuard guard;
  omp_set_num_threads(threads);
  const Shape shape{.length = length};
  Box box;
  const double scale = std::cbrt(static_cast<double>(bodies) / 150.0);
  box.length = {18.0 * scale, 20.0 * scale, 19.0 * scale};
  Particles p = random_gas(bodies, box, 9, true);
  const std::size_t n = p.size();
  const double dt = 0.002;
  NeighborList list;
  list.skin = 1.0;
  refresh_motion(p, n, shape, 0.5 * dt);
  long long found = 0, near_steps = 0;
  for (int step = 0; step < steps; ++step) {
    if (neighbor_list_expired(list, grow_bounds(p, n), n)) {
      list.unarmed_builds = 1;  // no watches: the pass over every pair
      build_neighbor_list(list, p, n, box, shape);
      grow_bounds(p, n);
    }
    NeighborList every = list;  // the same list, filtered by a pass over every pair
    std::vector<Found> near, all;
    const long long made = list.near.made;
    DetectionStats a, b;
    if constexpr (std::is_same_v<Found, Candidate>) {
      const StepAhead ahead{p.grow.data(), dt, true, 0.5 * dt};
      a = detect_candidates(p, box, shape, list, near, ahead);
      b = detect_candidates_all_pairs(p, box, shape, every, all, ahead);
    } else {
      a = detect_contacts(p, box, shape, list, near);
      b = detect_contacts_all_pairs(p, box, shape, every, all);
    }
    ASSERT_FALSE(a.watched);
    near_steps += list.near.made == made;
    ASSERT_EQ(a.narrow_phase_tests, b.narrow_phase_tests) << "step " << step;
    ASSERT_EQ(near.size(), all.size()) << "step " << step;
    for (std::size_t k = 0; k < all.size(); ++k) {
      ASSERT_EQ(near[k].id_i, all[k].id_i) << "step " << step;
      ASSERT_EQ(near[k].id_j, all[k].id_j) << "step " << step;
      if constexpr (std::is_same_v<Found, Candidate>) {
        ASSERT_EQ(near[k].spare, all[k].spare) << "step " << step;
      }
    }
    found += static_cast<long long>(all.size());
    fly_step(p, n, shape, 0.5 * dt);
    if (step % 20 == 0 || step % 20 == 10) {  // kicks, and back 10 steps later
      const double factor = step % 20 == 0 ? 2.5 : 1.0 / 2.5;
      for (std::size_t i = 0; i < n; ++i) {  // by id: a build sorts the bodies
        if ((p.id[i] / 7) % 7 != (step / 20) % 7) continue;
        p.set_velocity(i, factor * p.velocity(i));
        p.set_angular_velocity(i, factor * p.angular_velocity(i));
      }
      refresh_motion(p, n, shape, 0.5 * dt);
    }
  }
  EXPECT_GT(list.builds, 2);
  EXPECT_GT(found, 100) << "the test must find pairs";
  EXPECT_GT(near_steps, steps / 2) << "and read the near pairs at most steps";
}

TEST(Detection, NearPairsFindWhatEveryPairFinds) {
  for (const double length : {5.0, 0.0}) {
    check_near_pairs<Candidate>(length, 150, 1, 400);
    check_near_pairs<Contact>(length, 150, 1, 400);
  }
}

TEST(Detection, NearPairsFindWhatEveryPairFindsOnTwoThreads) {
  check_near_pairs<Candidate>(5.0, 2600, 2, 120);
  check_near_pairs<Contact>(0.0, 2600, 2, 120);
}

// The same with more bodies than kParallelBodies on two threads: the threads lower watches
// of bodies in each other's blocks (atomic minimum). Dropping that lowering fails here.
TEST(Detection, WatchesCoverEveryPairOnTwoThreads) { check_watches(4.0, 6400, 2, 400); }

// A rank holds a slab of the box, here one across the periodic boundary in x and a gap
// in y: the cell list keeps only the window of cells that holds bodies (not the box), and
// the list is still every pair within the reach, for rods and for spheres (one cell per
// reach at their occupancy).
TEST(Detection, ListOfASlabAcrossThePeriodicBoundary) {
  for (double length : {5.0, 0.0}) {
    Shape shape;
    shape.length = length;
    Box box;
    box.length = {80.0, 40.0, 24.0};
    const Particles gas = random_gas(12000, box, 11, length > 0);
    Particles p;
    for (std::size_t i = 0; i < gas.size(); ++i) {
      const Vec3 r = box.wrap(gas.position(i));
      if (!(r.x > 66.0 || r.x < 9.0) || (r.y > 14.0 && r.y < 27.0)) continue;
      const std::size_t k = p.size();
      p.resize(k + 1);
      p.id[k] = gas.id[i];
      p.set_position(k, gas.position(i));
      p.set_axis(k, gas.axis(i));
    }
    NeighborList list;
    list.skin = 0.3;
    build_neighbor_list(list, p, p.size(), box, shape);
    const CellList &cl = list.cells;
    EXPECT_LT(cl.extent[0], cl.cells[0]);
    EXPECT_LT(cl.extent[1], cl.cells[1]);
    EXPECT_EQ(cl.extent[2], cl.cells[2]);
    EXPECT_GT(cl.origin[0], cl.cells[0] / 2);  // the window starts right of the gap in x
    // The cell list renamed after the bodies were sorted is the one binning them again gives.
    CellList again;
    build_cell_list(again, p, p.size(), box, shape.length + shape.diameter + list.skin, true);
    EXPECT_EQ(cl.cells, again.cells);
    EXPECT_EQ(cl.origin, again.origin);
    EXPECT_EQ(cl.extent, again.extent);
    EXPECT_EQ(cl.cell_start, again.cell_start);
    EXPECT_EQ(cl.order, again.order);
    PairSet listed, expected;
    for (const ListedPair &pair : list.pairs)
      listed.insert({std::min(p.id[pair.first], p.id[pair.second]),
                     std::max(p.id[pair.first], p.id[pair.second])});
    const double h = shape.half_length();
    for (std::size_t i = 0; i < p.size(); ++i)
      for (std::size_t j = i + 1; j < p.size(); ++j) {
        const Vec3 r = box.minimum_image(p.position(j) - p.position(i));
        const auto sc = segment_closest(r, p.axis(i), h, p.axis(j), h);
        if (std::sqrt(sc.dist2) < shape.diameter + list.skin)
          expected.insert({std::min(p.id[i], p.id[j]), std::max(p.id[i], p.id[j])});
      }
    EXPECT_GT(expected.size(), 100u);
    EXPECT_EQ(listed, expected) << "length " << length;
    EXPECT_EQ(list.pairs.size(), listed.size()) << "a pair listed twice";
  }
}

TEST(Detection, ContactGeometryIsCanonical) {
  Shape shape;
  Box box;
  box.length = {20, 20, 20};
  Particles p;
  p.resize(2);
  p.id = {9, 3};  // storage order opposite to id order
  p.set_position(0, {10.0, 10.0, 10.0});
  p.set_position(1, {10.0, 10.9, 10.0});
  p.set_axis(0, {1, 0, 0});
  p.set_axis(1, {1, 0, 0});
  Contact c;
  double d = 0;
  ASSERT_TRUE(make_contact(p, box, box.inverse_length(), shape, 0, 1, c, d));
  EXPECT_EQ(c.id_i, 3);
  EXPECT_EQ(c.id_j, 9);
  EXPECT_NEAR(d, 0.9, 1e-14);
  EXPECT_NEAR(c.depth, 0.1, 1e-14);
  // Normal from j (id 9, lower y) to i (id 3, higher y).
  EXPECT_NEAR(c.normal.y, 1.0, 1e-14);
  // Parallel, fully overlapping: contact at the middle, no lever arm, no torque.
  EXPECT_NEAR(norm(c.arm_i), 0.0, 1e-14);
  EXPECT_NEAR(norm(c.arm_j), 0.0, 1e-14);
}

TEST(Detection, ContactAcrossThePeriodicBoundary) {
  Shape shape;
  Box box;
  box.length = {20, 20, 20};
  Particles p;
  p.resize(2);
  p.id = {0, 1};
  p.set_position(0, {0.2, 5.0, 5.0});
  p.set_position(1, {19.5, 5.0, 5.0});
  p.set_axis(0, {0, 0, 1});
  p.set_axis(1, {0, 0, 1});
  NeighborList list;
  build_neighbor_list(list, p, 2, box, shape);
  std::vector<Contact> contacts;
  detect_contacts(p, box, shape, list, contacts);
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_NEAR(contacts[0].depth, 1.0 - 0.7, 1e-12);
  EXPECT_NEAR(contacts[0].separation.x, 0.7, 1e-12);  // x_i - x_j through the boundary
}

// With shadows, a rank keeps the pairs with an owned body, and advances the shadows in them
// (the first ring). A chain of parallel rods 1 D apart, body 0 owned and bodies 1..4
// shadows: only the pair (0,1) is kept; (1,2), (2,3), (3,4) are left to the shadows'
// owners, and bodies 2, 3 and 4 go past list.active.
TEST(Detection, ShadowsBeyondTheFirstRingAreNotAdvanced) {
  Shape shape;
  Box box;
  box.length = {40, 40, 40};
  Particles p;
  p.resize(6);
  // Storage order scrambled on purpose: the build sorts owned bodies and shadows by cell.
  p.id = {0, 4, 2, 3, 1, 5};
  const double y[6] = {5.0, 9.0, 7.0, 8.0, 6.0, 30.0};  // id k at y = 5 + k, id 5 far away
  for (std::size_t i = 0; i < 6; ++i) {
    p.set_position(i, {10.0, y[i], 10.0});
    p.set_axis(i, {1, 0, 0});
  }
  NeighborList list;
  list.skin = 0.3;
  build_neighbor_list(list, p, 6, 1, box, shape);
  ASSERT_EQ(list.bodies, 6u);
  EXPECT_EQ(list.active, 2u);
  PairSet kept;
  for (std::size_t k = 0; k < list.pair_count(); ++k) {
    ASSERT_LT(list.pairs[k].first, list.active);
    ASSERT_LT(list.pairs[k].second, list.active);
    const std::int64_t a = p.id[list.pairs[k].first], b = p.id[list.pairs[k].second];
    kept.insert({std::min(a, b), std::max(a, b)});
  }
  EXPECT_EQ(kept, (PairSet{{0, 1}}));
  EXPECT_EQ(p.id[0], 0);
  EXPECT_EQ(p.id[1], 1);
  // Every body is still held, and its position travelled with its id.
  for (std::size_t i = 0; i < 6; ++i)
    EXPECT_EQ(p.position(i).y, 5.0 + (p.id[i] == 5 ? 25 : p.id[i]));

  // One rank (no shadows): every body is advanced and every pair kept.
  NeighborList all;
  build_neighbor_list(all, p, 6, box, shape);
  EXPECT_EQ(all.active, 6u);
  EXPECT_EQ(all.pair_count(), 4u);
}

}  // namespace
}  // namespace hardrod
