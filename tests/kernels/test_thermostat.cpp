// Kinetic energy and the rescaling thermostat (kernels/thermostat.hpp): the energy against a
// direct sum (translation 1/2 m v^2, rotation 1/2 I_perp w^2, none for spheres), the target
// (dof n - 3) kT / 2, and one rescaling that brings the energy to the target while the total
// momentum stays zero and every w stays perpendicular to its axis; the same bits for one and
// two threads.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <random>

#include "kernels/thermostat.hpp"

namespace hardrod {
namespace {

// Random velocities with zero total momentum; w perpendicular to a random axis.
Particles moving_bodies(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  Particles p;
  p.resize(n);
  Vec3 total;
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(i);
    const Vec3 e{g(rng), g(rng), g(rng)};
    p.set_axis(i, (1.0 / norm(e)) * e);
    p.set_velocity(i, {g(rng), g(rng), g(rng)});
    total += p.velocity(i);
    Vec3 w{g(rng), g(rng), g(rng)};
    w -= dot(w, p.axis(i)) * p.axis(i);
    p.set_angular_velocity(i, w);
  }
  for (std::size_t i = 0; i < n; ++i)
    p.set_velocity(i, p.velocity(i) - (1.0 / static_cast<double>(n)) * total);
  return p;
}

Vec3 momentum(const Particles &p, const Shape &shape) {
  Vec3 total;
  for (std::size_t i = 0; i < p.size(); ++i) total += shape.mass * p.velocity(i);
  return total;
}

TEST(Thermostat, KineticEnergyIsTheDirectSum) {
  const Particles p = moving_bodies(1000, 1);
  Shape rod;
  double translational = 0.0, rotational = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    translational += 0.5 * rod.mass * norm2(p.velocity(i));
    rotational += 0.5 * rod.inertia_perp() * norm2(p.angular_velocity(i));
  }
  const KineticEnergy k = kinetic_energy(p, p.size(), rod);
  EXPECT_NEAR(k.translational.value(), translational, 1e-12 * translational);
  EXPECT_NEAR(k.rotational.value(), rotational, 1e-12 * rotational);
  EXPECT_NEAR(k.total(), translational + rotational, 1e-12 * (translational + rotational));
  // Only [0, count).
  EXPECT_LT(kinetic_energy(p, 500, rod).total(), k.total());
  EXPECT_EQ(kinetic_energy(p, 0, rod).total(), 0.0);

  // Spheres do not rotate: their w, whatever it holds, carries no energy.
  Shape sphere;
  sphere.length = 0.0;
  const KineticEnergy s = kinetic_energy(p, p.size(), sphere);
  EXPECT_EQ(s.rotational.value(), 0.0);
  EXPECT_NEAR(s.total(), translational, 1e-12 * translational);
}

TEST(Thermostat, TargetIsDofNMinusThreeHalvesKT) {
  Shape rod, sphere;
  sphere.length = 0.0;
  EXPECT_DOUBLE_EQ(target_kinetic_energy(2304, rod, 1.0), 0.5 * (5 * 2304 - 3));
  EXPECT_DOUBLE_EQ(target_kinetic_energy(2304, rod, 2.5), 1.25 * (5 * 2304 - 3));
  EXPECT_DOUBLE_EQ(target_kinetic_energy(2197, sphere, 1.0), 0.5 * (3 * 2197 - 3));
}

// One rescaling, as the run applies it every thermostat_interval steps.
TEST(Thermostat, RescalingReachesTheTargetAndKeepsMomentumAndW) {
  for (const double length : {5.0, 0.0}) {
    SCOPED_TRACE("L = " + std::to_string(length));
    Shape shape;
    shape.length = length;
    Particles p = moving_bodies(2000, 2);
    const Particles before = p;
    const double target = target_kinetic_energy(2000, shape, 3.0);
    const double factor = std::sqrt(target / kinetic_energy(p, p.size(), shape).total());
    ASSERT_GT(std::fabs(factor - 1.0), 0.1) << "the test must change the energy";
    scale_velocities(p, p.size(), factor);
    EXPECT_NEAR(kinetic_energy(p, p.size(), shape).total(), target, 1e-12 * target);
    EXPECT_LT(norm(momentum(p, shape)), 1e-10);
    for (std::size_t i = 0; i < p.size(); ++i) {
      EXPECT_LT(std::fabs(dot(p.angular_velocity(i), p.axis(i))), 1e-12) << "body " << i;
      EXPECT_EQ(p.vx[i], before.vx[i] * factor);
      EXPECT_EQ(p.wz[i], before.wz[i] * factor);
      EXPECT_EQ(p.position(i).x, before.position(i).x);
      EXPECT_EQ(p.axis(i).y, before.axis(i).y);
    }
  }
}

TEST(Thermostat, ScalesOnlyTheFirstCountBodies) {
  Particles p = moving_bodies(10, 3);
  const Particles before = p;
  scale_velocities(p, 4, 2.0);
  for (std::size_t i = 0; i < 10; ++i)
    EXPECT_EQ(p.vy[i], i < 4 ? 2.0 * before.vy[i] : before.vy[i]) << "body " << i;
}

// Exact sums: the energy, and so the thermostat's factor, has the same bits on any thread
// count (above kParallelBodies, where the loop is split).
TEST(Thermostat, SameBitsOnOneAndTwoThreads) {
  const Particles p = moving_bodies(5000, 4);
  Shape rod;
  omp_set_num_threads(1);
  const double one = kinetic_energy(p, p.size(), rod).total();
  omp_set_num_threads(2);
  const double two = kinetic_energy(p, p.size(), rod).total();
  Particles a = p, b = p;
  scale_velocities(b, b.size(), 0.93);
  omp_set_num_threads(1);
  scale_velocities(a, a.size(), 0.93);
  EXPECT_EQ(one, two);
  EXPECT_EQ(a.vx, b.vx);
  EXPECT_EQ(a.wy, b.wy);
}

}  // namespace
}  // namespace hardrod
