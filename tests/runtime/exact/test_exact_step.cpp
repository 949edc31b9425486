// The exact method's whole steps (run.method = "exact", runtime/exact/exact_step.cpp): no pair ever
// overlaps (checked against every pair, not the list), energy is conserved to round-off, and
// the trajectory is the same bits for any thread count, and the same, to round-off, for any step.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "kernels/segment_geometry.hpp"
#include "runtime/system.hpp"
#include "tests/test_scenes.hpp"

namespace hardrod {
namespace {

Scene exact(Scene s) {
  s.method = kExact;
  return s;
}

// The smallest surface gap over all pairs (brute force, minimum image).
double smallest_gap(const System &sim) {
  const Particles &p = sim.particles();
  const Box &box = sim.scene().box;
  const Vec3 inverse = box.inverse_length();
  const double h = sim.scene().shape.half_length();
  double smallest = 1e300;
  for (std::size_t i = 0; i < sim.owned_count(); ++i)
    for (std::size_t j = i + 1; j < sim.owned_count(); ++j) {
      const Vec3 r = box.minimum_image(p.position(j) - p.position(i), inverse);
      if (norm2(r) > (2 * h + 2) * (2 * h + 2)) continue;
      const SegmentClosest c = segment_closest(r, p.axis(i), h, p.axis(j), h);
      smallest = std::min(smallest, std::sqrt(c.dist2) - sim.scene().shape.diameter);
    }
  return smallest;
}

TEST(ExactStep, NoPairEverOverlapsAndEnergyIsConserved) {
  for (const Scene &scene :
       {exact(testing::small_nematic(2e-3)), exact(testing::hard_spheres(8, 0.45, 2e-3))}) {
    omp_set_num_threads(1);
    System sim(scene);
    const double e0 = sim.kinetic_energy();
    double worst = 1e300;
    for (int k = 0; k < 250; ++k) {
      sim.step();
      worst = std::min(worst, smallest_gap(sim));
    }
    const IntervalTotals t = sim.take_interval();
    EXPECT_GT(t.collisions, 100) << scene.shape_name;
    EXPECT_GT(worst, -1e-9) << scene.shape_name;
    EXPECT_NEAR(sim.kinetic_energy() / e0, 1.0, 1e-11) << scene.shape_name;
    EXPECT_EQ(testing::exact_record(sim).totals.fallbacks, 0) << scene.shape_name;
  }
}

// Large enough (2744 spheres, ~100 clusters per step) that the clusters are solved in
// parallel (kParallelClusters) and the detection and flight passes are threaded.
TEST(ExactStep, SameStateForAnyThreadCount) {
  for (const Scene &scene :
       {exact(testing::small_nematic(2e-3)), exact(testing::hard_spheres(14, 0.45, 2e-3))}) {
    std::string reference;
    for (int threads : {1, 2, 3}) {
      omp_set_num_threads(threads);
      System sim(scene);
      sim.advance(300);
      if (reference.empty())
        reference = sim.state_checksum();
      else
        EXPECT_EQ(sim.state_checksum(), reference) << threads << " threads, " << scene.shape_name;
    }
  }
  omp_set_num_threads(1);
}

// Extending the list body by body (kernels/exact/list_extension.hpp) changes which pairs are
// measured, never what touches: the same bits as a build at every expiry, on one thread and
// two, with fewer builds. 4096 spheres (a budget of 16 extensions a list) and 288 rods (one,
// with near pairs).
TEST(ExactStep, ExtendedListsGiveTheSameBitsWithFewerBuilds) {
  Scene spheres = exact(testing::hard_spheres(16, 0.45, 4e-3)),
        rods = exact(testing::small_nematic(1e-3));
  spheres.skin = 0.5;
  rods.skin = 1.0;
  for (const auto &[scene, steps] : {std::pair{spheres, 400}, std::pair{rods, 1500}})
    for (int threads : {1, 2}) {
      omp_set_num_threads(threads);
      ParallelOptions plain;
      plain.extend_lists = false;
      System extended(scene), built(scene, plain);
      extended.advance(steps);
      built.advance(steps);
      const std::string where = scene.shape_name + ", " + std::to_string(threads) + " threads";
      EXPECT_EQ(extended.state_checksum(), built.state_checksum()) << where;
      EXPECT_EQ(testing::list_extension(built).extensions, 0);
      EXPECT_GT(testing::list_extension(extended).extensions, 0) << where;
      EXPECT_LT(extended.neighbor_list().builds, built.neighbor_list().builds) << where;
      EXPECT_EQ(extended.take_interval().collisions, built.take_interval().collisions) << where;
    }
  omp_set_num_threads(1);
}

// How far two runs of one scene ended apart: the largest difference, body by body (matched by
// id), of the position (minimum image), axis, velocity and angular velocity.
double largest_difference(const System &a, const System &b) {
  const Particles &p = a.particles(), &q = b.particles();
  const Box &box = a.scene().box;
  const Vec3 inverse = box.inverse_length();
  std::vector<std::size_t> at(a.owned_count());
  for (std::size_t k = 0; k < b.owned_count(); ++k) at[static_cast<std::size_t>(q.id[k])] = k;
  double worst = 0.0;
  for (std::size_t k = 0; k < a.owned_count(); ++k) {
    const std::size_t m = at[static_cast<std::size_t>(p.id[k])];
    worst = std::max({worst, norm(box.minimum_image(p.position(k) - q.position(m), inverse)),
                      norm(p.axis(k) - q.axis(m)), norm(p.velocity(k) - q.velocity(m)),
                      norm(p.angular_velocity(k) - q.angular_velocity(m))});
  }
  return worst;
}

// The exact method takes every collision at its time, so the step is only how often the pairs
// are looked at: 0.2 tau in steps of 1e-3, 2e-3 and 4e-3 give the same collisions and the same
// end state, to the round-off the search's tolerance leaves. The midpoint method, which resolves
// overlaps, does not: the same comparison of its runs fails by far, so this one can fail.
TEST(ExactStep, TheTrajectoryDoesNotDependOnTheStep) {
  for (const Scene &base : {testing::small_nematic(), testing::hard_spheres(8, 0.45)}) {
    const auto run = [&](int method, double dt, IntervalTotals &totals) {
      Scene s = base;
      s.method = method;
      s.dt = dt;
      s.skin = 1.0;
      auto sim = std::make_unique<System>(s);
      sim->advance(static_cast<long long>(std::lround(0.2 / dt)));
      totals = sim->take_interval();
      return sim;
    };
    // Measured: 2e-8 - 8e-8 for the rods (their contact times converged to 1e-10 D, then
    // amplified by ~3 collisions a body), 3e-11 - 5e-11 for the spheres (closed form); the
    // midpoint method's runs end 4-5 D apart.
    const double tolerance = base.shape.half_length() > 0.0 ? 1e-6 : 1e-9;
    omp_set_num_threads(1);
    IntervalTotals fine;
    const auto reference = run(kExact, 1e-3, fine);
    ASSERT_GT(fine.collisions, 200) << base.shape_name;
    for (const double dt : {2e-3, 4e-3}) {
      IntervalTotals coarse;
      const auto other = run(kExact, dt, coarse);
      EXPECT_EQ(coarse.collisions, fine.collisions) << base.shape_name << ", dt " << dt;
      EXPECT_NEAR(coarse.virial.value() / fine.virial.value(), 1.0, 1e-9) << base.shape_name;
      EXPECT_LT(largest_difference(*reference, *other), tolerance)
          << base.shape_name << ", dt " << dt;
    }
    IntervalTotals unused;
    const auto midpoint = run(kMidpoint, 1e-3, unused), midpoint2 = run(kMidpoint, 2e-3, unused);
    EXPECT_GT(largest_difference(*midpoint, *midpoint2), 1e-2) << base.shape_name;
  }
}

// A start that overlaps slightly (the midpoint method leaves overlaps of ~1e-4 D in its end
// states) with the pair receding: the pass leaves the pair to part instead of taking its
// "contact" again and again until the event cap.
TEST(ExactStep, OverlappingRecedingStartPartsWithoutFallback) {
  Scene scene = exact(testing::hard_spheres(3, 0.2, 1e-3));
  Particles bodies = initial_bodies(scene);
  // Bodies 0 and 1 neighbours along x: put 1 at 0.9999 D from 0, moving apart.
  bodies.set_position(1, bodies.position(0) + Vec3{0.9999, 0.0, 0.0});
  bodies.set_velocity(0, {-1.0, 0.0, 0.0});
  bodies.set_velocity(1, {1.0, 0.0, 0.0});
  System sim(scene, bodies);
  sim.advance(50);
  EXPECT_EQ(testing::exact_record(sim).totals.fallbacks, 0);
  EXPECT_LE(testing::exact_record(sim).totals.events, 1000);
  EXPECT_GT(smallest_gap(sim), -1e-9);
}

// A step's flight longer than half the skin cannot be covered by the list: a clear error
// naming both keys, not a missed collision.
// 216 bodies, and 4096 (where the list may be extended instead of built: list_extension.hpp;
// a runaway is still the build's to refuse).
TEST(ExactStep, AFlightBeyondTheSkinIsRefusedByName) {
  for (const int side : {6, 16}) {
    Scene scene = exact(testing::hard_spheres(side, 0.3, 2e-3));
    scene.skin = 0.002;
    System sim(scene);
    try {
      sim.advance(10);
      FAIL() << "no error, " << scene.n << " bodies";
    } catch (const PhysicsError &e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("run.dt = 0.002"), std::string::npos) << what;
      EXPECT_NE(what.find("run.skin = 0.002"), std::string::npos) << what;
    }
  }
  // One runaway among 4096 bodies with a fitting skin (a step of 0.3 D against half the skin,
  // 0.25): refused at the first step, as with any list.
  Scene scene = exact(testing::hard_spheres(16, 0.3, 2e-3));
  scene.skin = 0.5;
  Particles bodies = initial_bodies(scene);
  bodies.set_velocity(7, {150.0, 0.0, 0.0});
  System sim(scene, bodies);
  try {
    sim.advance(1);
    FAIL() << "no error for a runaway";
  } catch (const PhysicsError &e) {
    EXPECT_NE(std::string(e.what()).find("flight in one step"), std::string::npos) << e.what();
  }
}

// A NaN velocity stops the run at the next step, naming it, instead of flying on.
TEST(ExactStep, ANaNVelocityStopsTheRun) {
  Scene scene = exact(testing::hard_spheres(6, 0.3, 1e-3));
  System sim(scene);
  sim.advance(5);
  sim.particles().vx[7] = std::nan("");
  try {
    sim.advance(5);
    FAIL() << "no error";
  } catch (const PhysicsError &e) {
    EXPECT_NE(std::string(e.what()).find("NaN"), std::string::npos) << e.what();
  }
}

// A body that a collision speeds up can outrun the list within a step: sphere A moves along +y
// (its bound grows with every step), B comes along -x and gives A its x velocity, so A's flight
// after the collision is longer than its bound allowed and, with this skin, beyond half of it.
// The step is solved again on a list built at its start: the same state as with a skin that
// never needs it.
TEST(ExactStep, AFlightBeyondTheSkinWithinAStepRebuildsAndSolvesAgain) {
  const auto run = [](double skin, long long &rebuilt) {
    Scene s;
    s.shape_name = "sphere";
    s.shape.length = 0.0;
    s.n = 2;
    s.lattice = {2, 1, 1};
    s.box.length = {20, 20, 20};
    s.dt = 0.01;
    s.method = kExact;
    s.skin = skin;
    s.thermostat_interval = 0;
    Particles b;
    b.resize(2);
    b.id = {0, 1};
    const double t_hit = 4.1 * s.dt;
    b.set_position(0, {10, 10, 10});
    b.set_velocity(0, {0, 2, 0});
    b.set_axis(0, {1, 0, 0});
    b.set_position(1, {11 + 2 * t_hit, 10 + 2 * t_hit, 10});
    b.set_velocity(1, {-2, 0, 0});
    b.set_axis(1, {1, 0, 0});
    System sim(s, b);
    sim.advance(20);
    rebuilt = testing::exact_record(sim).rebuilt_in_step;
    EXPECT_EQ(testing::exact_record(sim).totals.collisions, 1);
    EXPECT_NEAR(sim.particles().vx[sim.particles().id[0] == 0 ? 0 : 1], -2.0, 1e-9);
    return sim.state_checksum();
  };
  long long tight = 0, wide = 0;
  const std::string a = run(0.21, tight), b = run(1.0, wide);
  EXPECT_EQ(tight, 1);
  EXPECT_EQ(wide, 0);
  EXPECT_EQ(a, b);
}

}  // namespace
}  // namespace hardrod
