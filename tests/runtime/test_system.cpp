// Whole time steps: thread-count invariance bit for bit, time reversibility, energy
// conservation without thermostat, and the physics-break stop.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>

#include "runtime/system.hpp"
#include "tests/test_scenes.hpp"

namespace hardrod {
namespace {

void run_steps(System &sim, long long steps) {
  for (long long k = 0; k < steps; ++k) sim.step();
}

TEST(System, SameStateForAnyThreadCount) {
  for (const Scene &scene : {testing::small_nematic(), testing::hard_spheres(8, 0.45)}) {
    std::string reference;
    long long reference_collisions = -1;
    for (int threads : {1, 2, 3}) {
      omp_set_num_threads(threads);
      System sim(scene);
      run_steps(sim, 600);
      const long long collisions = sim.take_interval().collisions;
      EXPECT_GT(collisions, 50) << scene.shape_name;
      if (reference.empty()) {
        reference = sim.state_checksum();
        reference_collisions = collisions;
      } else {
        EXPECT_EQ(sim.state_checksum(), reference) << threads << " threads, " << scene.shape_name;
        EXPECT_EQ(collisions, reference_collisions);
      }
    }
  }
  omp_set_num_threads(1);
}

// Steps in bursts (the run loop's way, with the half steps between steps fused) give the
// bits of one step() at a time, across the rotor-constraint (100) and thermostat (every 50
// here) steps, for rods and spheres.
TEST(System, BurstsOfStepsEqualSingleSteps) {
  for (Scene scene : {testing::small_nematic(), testing::hard_spheres(8, 0.45)}) {
    scene.thermostat_interval = 50;
    System single(scene), bursts(scene);
    run_steps(single, 437);
    for (const long long burst : {1, 7, 64, 150, 215}) bursts.advance(burst);
    ASSERT_EQ(bursts.current_step(), 437);
    const long long collisions = single.take_interval().collisions;
    EXPECT_GT(collisions, 50) << scene.shape_name;
    EXPECT_EQ(bursts.take_interval().collisions, collisions);
    EXPECT_EQ(bursts.state_checksum(), single.state_checksum()) << scene.shape_name;
  }
}

// The drift reads motion constants computed when velocities change (refresh_motion), not
// every half step. One step() at a time refreshes them at the start of every step; bursts
// keep them current through impulses and the thermostat (every 30 steps here, on bodies
// started 20 % too fast, so that it changes every velocity) and the rotor constraints (on
// bodies started with a spin about their axis): the same bits either way. (A rebuild on one rank
// only reorders bodies, constants with them; the new bodies and shadows of a rebuild on several
// ranks are the parallel matrix's.)
TEST(System, MotionConstantsFollowEveryVelocityChange) {
  for (Scene scene : {testing::small_nematic(1e-3), testing::hard_spheres(8, 0.45)}) {
    scene.thermostat_interval = 30;
    Particles fast = initial_bodies(scene);
    for (auto *v : {&fast.vx, &fast.vy, &fast.vz, &fast.wx, &fast.wy, &fast.wz})
      for (double &x : *v) x *= 1.2;
    // A spin about the axis too, which the rotor constraints (step 100) take out again.
    for (std::size_t i = 0; i < fast.size(); ++i)
      fast.set_angular_velocity(i, fast.angular_velocity(i) + 0.3 * fast.axis(i));
    System single(scene, fast), bursts(scene, fast);
    const double hot = single.kinetic_energy();
    run_steps(single, 345);
    for (const long long burst : {3, 17, 64, 29, 101, 64, 2, 65}) bursts.advance(burst);
    ASSERT_EQ(bursts.current_step(), 345);
    EXPECT_LT(single.kinetic_energy(), 0.8 * hot) << scene.shape_name;  // the thermostat acted
    const long long collisions = single.take_interval().collisions;
    EXPECT_GT(collisions, 50) << scene.shape_name;
    EXPECT_EQ(bursts.take_interval().collisions, collisions);
    EXPECT_EQ(bursts.state_checksum(), single.state_checksum()) << scene.shape_name;
  }
}

// The trajectory depends on the bodies, not on where they sit in memory: start from the same
// state stored in a shuffled order and the final state must be the same, bit for bit.
TEST(System, SameStateForAnyStorageOrder) {
  const Scene scene = testing::small_nematic();
  System reference(scene);
  Particles shuffled = reference.particles();
  std::vector<std::uint32_t> order(shuffled.size());
  for (std::size_t k = 0; k < order.size(); ++k)
    order[k] = static_cast<std::uint32_t>((k * 97) % order.size());  // 97 is coprime to 288
  shuffled.permute(order);
  ASSERT_NE(shuffled.id, reference.particles().id);
  System other(scene, shuffled);
  run_steps(reference, 800);
  run_steps(other, 800);
  EXPECT_GT(reference.take_interval().collisions, 50);
  EXPECT_EQ(other.state_checksum(), reference.state_checksum());
}

// Forward, reverse every velocity, the same number of steps back: the start returns.
// Hard-body dynamics is chaotic, so round-off grows by orders of magnitude over the run;
// 1500 steps of dt = 1e-4 (0.15 tau, about 5 collisions per rod) stay within 1e-7 D.
TEST(System, TimeReversible) {
  for (const Scene &scene : {testing::small_nematic(), testing::hard_spheres(7, 0.40)}) {
    System sim(scene);
    const Particles start = sim.particles();
    run_steps(sim, 1500);
    const long long collisions = sim.take_interval().collisions;
    ASSERT_GT(collisions, 100) << "the test must include collisions";
    Particles &p = sim.particles();
    for (std::size_t i = 0; i < p.size(); ++i) {
      p.set_velocity(i, -p.velocity(i));
      p.set_angular_velocity(i, -p.angular_velocity(i));
    }
    run_steps(sim, 1500);
    // Storage order changes when the neighbour list sorts bodies by cell: match by id.
    std::vector<std::size_t> where(p.size());
    for (std::size_t i = 0; i < start.size(); ++i) where[static_cast<std::size_t>(start.id[i])] = i;
    double worst_x = 0, worst_e = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const std::size_t k = where[static_cast<std::size_t>(p.id[i])];
      const Vec3 d = scene.box.minimum_image(p.position(i) - start.position(k));
      worst_x = std::max(worst_x, norm(d));
      worst_e = std::max(worst_e, norm(p.axis(i) - start.axis(k)));
    }
    EXPECT_LT(worst_x, 1e-7) << scene.shape_name;
    EXPECT_LT(worst_e, 1e-7) << scene.shape_name;
    EXPECT_EQ(sim.take_interval().collisions, collisions);
  }
}

// Without thermostat, isolated collisions conserve kinetic energy exactly; what drifts is
// the multi-contact clusters, which become rarer as dt shrinks.
TEST(System, EnergyDriftShrinksWithDt) {
  double previous = -1;
  for (double dt : {1e-3, 2.5e-4, 6.25e-5}) {
    System sim(testing::small_nematic(dt));
    const double e0 = sim.kinetic_energy();
    run_steps(sim, static_cast<long long>(std::llround(0.25 / dt)));
    const double drift = std::fabs(sim.kinetic_energy() / e0 - 1.0);
    RecordProperty("drift_dt_" + std::to_string(dt), std::to_string(drift));
    std::printf("dt = %g: relative kinetic energy change over 0.25 tau = %.3e\n", dt, drift);
    if (previous >= 0) {
      EXPECT_LE(drift, previous + 1e-12);
    }
    previous = drift;
  }
  EXPECT_LT(previous, 1e-6);
}

TEST(System, StopsWhenDtBreaksThePhysics) {
  Scene scene = testing::small_nematic(0.05);
  scene.max_overlap = 0.05;
  System sim(scene);
  try {
    run_steps(sim, 2000);
    FAIL() << "a dt of 0.05 must produce overlaps beyond 0.05 D";
  } catch (const PhysicsError &e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("run.dt = 0.05"), std::string::npos) << msg;
    EXPECT_NE(msg.find("step "), std::string::npos) << msg;
  }
}

TEST(System, ThermostatRestoresTargetEnergy) {
  Scene scene = testing::small_nematic(1e-3);
  scene.thermostat_interval = 50;
  System sim(scene);
  run_steps(sim, 200);
  EXPECT_NEAR(sim.kinetic_energy() / sim.target_kinetic_energy(), 1.0, 1e-12);
  EXPECT_EQ(sim.thermostat_record().applications, 4);
  EXPECT_TRUE(std::isfinite(sim.thermostat_record().correction_sum));
}

}  // namespace
}  // namespace hardrod
