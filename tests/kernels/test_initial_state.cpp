// The initial state (kernels/initial_state.hpp): the lattice (count, ids in x-fastest order,
// spacing box / counts, centres inside the box, every axis along the chosen one, density n/V)
// and the velocities (zero total momentum, kinetic energy exactly (dof n - 3) kT / 2, w
// perpendicular to the axis, roughly equipartitioned, the same bits for a seed and for a body
// wherever it is stored, other bits for another seed; spheres get no w).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "kernels/initial_state.hpp"
#include "kernels/thermostat.hpp"

namespace hardrod {
namespace {

Box everyday_box() {
  Box box;
  box.length = {28.5256, 28.5256, 28.5256};
  return box;
}

TEST(InitialState, LatticeCountIdsSpacingAndAxis) {
  const Box box = everyday_box();
  const std::array<long long, 3> lattice{4, 24, 24};
  for (int axis = 0; axis < 3; ++axis) {
    SCOPED_TRACE("axis " + std::to_string(axis));
    Particles p;
    place_on_lattice(p, box, lattice, axis);
    ASSERT_EQ(p.size(), 2304u);
    EXPECT_NEAR(static_cast<double>(p.size()) / box.volume(), 2304 / std::pow(28.5256, 3), 1e-15);
    const Vec3 spacing{28.5256 / 4, 28.5256 / 24, 28.5256 / 24};
    std::size_t k = 0;
    for (long long iz = 0; iz < 24; ++iz)
      for (long long iy = 0; iy < 24; ++iy)
        for (long long ix = 0; ix < 4; ++ix, ++k) {
          EXPECT_EQ(p.id[k], static_cast<std::int64_t>(k));  // x fastest
          EXPECT_NEAR(p.x[k], (static_cast<double>(ix) + 0.5) * spacing.x, 1e-12);
          EXPECT_NEAR(p.y[k], (static_cast<double>(iy) + 0.5) * spacing.y, 1e-12);
          EXPECT_NEAR(p.z[k], (static_cast<double>(iz) + 0.5) * spacing.z, 1e-12);
          EXPECT_EQ(p.axis(k).x, axis == 0 ? 1.0 : 0.0);
          EXPECT_EQ(p.axis(k).y, axis == 1 ? 1.0 : 0.0);
          EXPECT_EQ(p.axis(k).z, axis == 2 ? 1.0 : 0.0);
          EXPECT_EQ(p.motion_bound[k], 0.0);
          for (const double c : {p.x[k], p.y[k], p.z[k]}) {
            EXPECT_GT(c, 0.0);
            EXPECT_LT(c, 28.5256);
          }
        }
    // Neighbours along each axis are one spacing apart, also across the periodic boundary.
    EXPECT_NEAR(box.minimum_image(p.position(1) - p.position(0)).x, spacing.x, 1e-12);
    EXPECT_NEAR(box.minimum_image(p.position(0) - p.position(3)).x, spacing.x, 1e-12);
    EXPECT_NEAR(p.y[4] - p.y[0], spacing.y, 1e-12);
    EXPECT_NEAR(p.z[96] - p.z[0], spacing.z, 1e-12);
  }
  Particles one;
  place_on_lattice(one, box, {1, 1, 1}, 0);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_NEAR(one.x[0], 0.5 * 28.5256, 1e-12);
}

// Velocities as a run draws them, after place_on_lattice.
Particles started(const Shape &shape, std::uint64_t seed, double kT, int axis = 0) {
  Particles p;
  place_on_lattice(p, everyday_box(), {4, 24, 24}, axis);
  assign_velocities(p, shape, seed, kT);
  return p;
}

TEST(InitialState, ZeroMomentumExactTargetEnergyAndWPerpendicular) {
  Shape rod;
  for (const double kT : {1.0, 0.37}) {
    const Particles p = started(rod, 1, kT, 1);
    Vec3 total;
    for (std::size_t i = 0; i < p.size(); ++i) {
      total += rod.mass * p.velocity(i);
      EXPECT_LT(std::fabs(dot(p.angular_velocity(i), p.axis(i))), 1e-15) << "body " << i;
    }
    EXPECT_LT(norm(total), 1e-11);
    const double target = target_kinetic_energy(2304, rod, kT);
    const KineticEnergy k = kinetic_energy(p, p.size(), rod);
    EXPECT_NEAR(k.total(), target, 1e-12 * target);
    // Roughly equipartitioned: 3 of the 5 degrees of freedom translate (2304 bodies: ~2 %).
    EXPECT_NEAR(k.translational.value() / k.total(), 0.6, 0.05);
  }
}

TEST(InitialState, ReproducibleForASeedAndIndependentOfStorageOrder) {
  Shape rod;
  const Particles a = started(rod, 7, 1.0), b = started(rod, 7, 1.0), c = started(rod, 8, 1.0);
  EXPECT_EQ(a.vx, b.vx);
  EXPECT_EQ(a.wz, b.wz);
  EXPECT_NE(a.vx, c.vx);
  EXPECT_NE(a.wy, c.wy);

  // The same bodies stored in reverse order get the same velocities, bit for bit (draws are
  // keyed by id, the sums are exact): what the decomposition relies on.
  Particles reversed;
  place_on_lattice(reversed, everyday_box(), {4, 24, 24}, 0);
  std::vector<std::uint32_t> order(reversed.size());
  std::iota(order.rbegin(), order.rend(), 0u);
  reversed.permute(order);
  assign_velocities(reversed, rod, 7, 1.0);
  for (std::size_t k = 0; k < a.size(); ++k) {
    const std::size_t r = a.size() - 1 - k;
    ASSERT_EQ(reversed.id[r], a.id[k]);
    EXPECT_EQ(reversed.velocity(r).x, a.velocity(k).x);
    EXPECT_EQ(reversed.velocity(r).z, a.velocity(k).z);
    EXPECT_EQ(reversed.angular_velocity(r).y, a.angular_velocity(k).y);
  }
}

TEST(InitialState, SpheresGetNoAngularVelocity) {
  Shape sphere;
  sphere.length = 0.0;
  const Particles p = started(sphere, 3, 1.0);
  for (std::size_t i = 0; i < p.size(); ++i) EXPECT_EQ(norm2(p.angular_velocity(i)), 0.0);
  const double target = target_kinetic_energy(2304, sphere, 1.0);
  EXPECT_NEAR(kinetic_energy(p, p.size(), sphere).total(), target, 1e-12 * target);
}

}  // namespace
}  // namespace hardrod
