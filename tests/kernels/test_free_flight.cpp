// Free flight: exact free rotation of a linear rotor, unit axes, and motion bounds that
// really bound how far every point of a body moved.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <utility>

#include "kernels/free_flight.hpp"
#include "kernels/rotor_constraints.hpp"

namespace hardrod {
namespace {

TEST(FreeFlight, FreeRotationIsExact) {
  Shape shape;
  Particles p;
  p.resize(1);
  p.set_axis(0, {1, 0, 0});
  p.set_angular_velocity(0, {0, 0, 2.0});  // 2 rad per tau about z
  const double half_dt = 1e-3;
  for (int k = 0; k < 1000; ++k) half_step(p, 1, shape, half_dt);
  const double angle = 2.0 * 1000 * half_dt;
  EXPECT_NEAR(p.ex[0], std::cos(angle), 1e-13);
  EXPECT_NEAR(p.ey[0], std::sin(angle), 1e-13);
  EXPECT_NEAR(p.ez[0], 0.0, 1e-15);
  // Not renormalised every step: the norm drifts by round-off only...
  EXPECT_NEAR(norm(p.axis(0)), 1.0, 1e-13);
  // ...and restore_rotor_constraints brings it back.
  restore_rotor_constraints(p, 1);
  EXPECT_NEAR(norm(p.axis(0)), 1.0, 2e-16);
}

TEST(FreeFlight, MotionBoundCoversEveryPointOfTheBody) {
  std::mt19937_64 rng(1);
  std::normal_distribution<double> g;
  Shape shape;
  shape.length = 50.0;  // long rods: rotation dominates
  Particles p;
  const std::size_t n = 500;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    Vec3 e{g(rng), g(rng), g(rng)};
    p.set_axis(i, (1 / norm(e)) * e);
    p.set_velocity(i, {g(rng), g(rng), g(rng)});
    Vec3 w{g(rng), g(rng), g(rng)};
    w -= dot(w, p.axis(i)) * p.axis(i);
    p.set_angular_velocity(i, w);
  }
  const Particles start = p;
  for (int k = 0; k < 100; ++k) half_step(p, n, shape, 0.01);
  for (std::size_t i = 0; i < n; ++i) {
    for (double s : {-25.0, -10.0, 0.0, 12.5, 25.0}) {
      const Vec3 before = start.position(i) + s * start.axis(i);
      const Vec3 after = p.position(i) + s * p.axis(i);
      EXPECT_LE(norm(after - before), p.motion_bound[i]) << i;
    }
    EXPECT_NEAR(norm(p.axis(i)), 1.0, 1e-13);
  }
}

TEST(FreeFlight, SpheresDoNotRotate) {
  Shape sphere;
  sphere.length = 0.0;
  Particles p;
  p.resize(1);
  p.set_axis(0, {0, 1, 0});
  p.set_velocity(0, {1, 2, 3});
  p.set_angular_velocity(0, {5, 0, 0});
  half_step(p, 1, sphere, 0.5);
  EXPECT_EQ(p.ey[0], 1.0);
  EXPECT_DOUBLE_EQ(p.x[0], 0.5);
  EXPECT_DOUBLE_EQ(p.z[0], 1.5);
}

TEST(FreeFlight, ReturnsTheLargestMotionBound) {
  Shape shape;
  Particles p;
  p.resize(3);
  for (std::size_t i = 0; i < 3; ++i) p.set_axis(i, {1, 0, 0});
  p.set_velocity(0, {1, 0, 0});
  p.set_velocity(1, {0, -3, 0});
  p.set_angular_velocity(2, {0, 0, 1});  // L/2 |w| = 2.5
  const double largest = half_step(p, 3, shape, 0.1);
  EXPECT_DOUBLE_EQ(largest, *std::max_element(p.motion_bound.begin(), p.motion_bound.end()));
  EXPECT_NEAR(largest, 0.3, 1e-12);
  EXPECT_GT(p.motion_bound[2], 0.25);
}

// The fused pass (second half of a step with the first half of the next) must give the bits
// of two half steps, for rods and spheres, on the vector and threaded path (n above the
// parallel threshold), including bodies whose angle takes the library rotation.
TEST(FreeFlight, TwoHalfStepsInOnePassEqualTwoHalfSteps) {
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  for (const bool sphere : {false, true}) {
    Shape shape;
    if (sphere) shape.length = 0.0;
    const std::size_t n = 5000;
    Particles p;
    p.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      p.id[i] = static_cast<std::int64_t>(i);
      p.set_position(i, {g(rng), g(rng), g(rng)});
      const Vec3 e{g(rng), g(rng), g(rng)};
      p.set_axis(i, (1.0 / std::sqrt(norm2(e))) * e);
      p.set_velocity(i, {g(rng), g(rng), g(rng)});
      // Every 50th body spins fast enough for the library rotation at this half step.
      const double spin = i % 50 == 0 ? 3000.0 : 1.0;
      p.set_angular_velocity(i, {spin * g(rng), spin * g(rng), spin * g(rng)});
      p.motion_bound[i] = 0.01 * static_cast<double>(i % 7);
    }
    for (const int threads : {1, 2}) {
      omp_set_num_threads(threads);
      Particles a = p, b = p;
      half_step(a, n, shape, 5e-5);
      const double largest_a = half_step(a, n, shape, 5e-5);
      const double largest_b = two_half_steps(b, n, shape, 5e-5);
      EXPECT_EQ(largest_a, largest_b);
      for (const auto &[u, v] : {std::pair{&a.x, &b.x},
                                 {&a.y, &b.y},
                                 {&a.z, &b.z},
                                 {&a.ex, &b.ex},
                                 {&a.ey, &b.ey},
                                 {&a.ez, &b.ez},
                                 {&a.motion_bound, &b.motion_bound}})
        ASSERT_EQ(*u, *v) << (sphere ? "spheres" : "rods") << ", " << threads << " threads";
      if (!sphere) {
        EXPECT_NE(a.ex, p.ex);  // the axes did turn
      }
      // The exact method's split: the bounds grown first, then the flight without them, give
      // the same bits (and the largest bound) as two_half_steps.
      Particles c = p;
      refresh_motion(c, n, shape, 5e-5);
      EXPECT_EQ(grow_bounds(c, n), largest_b);
      fly_step(c, n, shape, 5e-5);
      for (const auto &[u, v] : {std::pair{&c.x, &b.x},
                                 {&c.y, &b.y},
                                 {&c.z, &b.z},
                                 {&c.ex, &b.ex},
                                 {&c.ey, &b.ey},
                                 {&c.ez, &b.ez},
                                 {&c.motion_bound, &b.motion_bound}})
        ASSERT_EQ(*u, *v) << "grow_bounds + fly_step, " << (sphere ? "spheres" : "rods");
    }
    omp_set_num_threads(1);
  }
}

}  // namespace
}  // namespace hardrod
