// make_isotropic against an O(N^2) overlap check with segment_closest: no pair closer than D
// at the target density, for rods and hard spheres and for one, two and ten bodies; ids in
// order, positions folded into the exact target box, unit axes, zero velocities; S small
// (isotropic) for rods at moderate density; the same bits for the same seed whatever the
// thread count, different bits for another seed; clear exceptions for an unreachable target
// and bad arguments. The DISABLED_ test is the timing experiment of the everyday scene
// (run it with --gtest_also_run_disabled_tests).
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "kernels/isotropic_start.hpp"
#include "kernels/order_tensor.hpp"
#include "kernels/segment_geometry.hpp"
#include "tests/thread_count_guard.hpp"

namespace hardrod {
namespace {

Box cube(double side) {
  Box box;
  box.length = {side, side, side};
  return box;
}

// Cubic box of n rods at reduced density rho / rho_cp.
Box box_at_reduced_density(long long n, const Shape &shape, double reduced) {
  return cube(std::cbrt(static_cast<double>(n) / (reduced * shape.close_packing_density())));
}

Box box_at_packing_fraction(long long n, const Shape &shape, double eta) {
  return cube(std::cbrt(static_cast<double>(n) * shape.volume() / eta));
}

struct AllPairs {
  long long overlaps = 0;
  double min_gap = std::numeric_limits<double>::infinity();
};

AllPairs brute_force(const Particles &p, const Shape &shape, const Box &box) {
  AllPairs out;
  const double h = shape.half_length();
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      const Vec3 r = box.minimum_image(p.position(j) - p.position(i));
      const double d2 = segment_closest(r, p.axis(i), h, p.axis(j), h).dist2;
      if (d2 < shape.diameter * shape.diameter) ++out.overlaps;
      out.min_gap = std::min(out.min_gap, std::sqrt(d2) - shape.diameter);
    }
  return out;
}

// Everything the result must satisfy whatever the density; returns the all-pairs check.
AllPairs expect_valid(const Particles &p, long long n, const Shape &shape, const Box &box,
                      const CompressionReport &report) {
  EXPECT_EQ(p.size(), static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < p.size(); ++i) {
    EXPECT_EQ(p.id[i], static_cast<std::int64_t>(i));
    EXPECT_TRUE(p.x[i] >= 0.0 && p.x[i] < box.length.x) << p.x[i];
    EXPECT_TRUE(p.y[i] >= 0.0 && p.y[i] < box.length.y) << p.y[i];
    EXPECT_TRUE(p.z[i] >= 0.0 && p.z[i] < box.length.z) << p.z[i];
    EXPECT_NEAR(norm(p.axis(i)), 1.0, 1e-14);
    EXPECT_EQ(norm2(p.velocity(i)), 0.0);
    EXPECT_EQ(norm2(p.angular_velocity(i)), 0.0);
  }
  const AllPairs pairs = brute_force(p, shape, box);
  EXPECT_EQ(pairs.overlaps, 0);
  EXPECT_TRUE(report.reached);
  EXPECT_GE(report.min_distance, 0.0);
  EXPECT_EQ(report.min_distance, std::min(shape.diameter, pairs.min_gap));
  EXPECT_EQ(report.order_parameter, order_parameter(axis_moments(p, p.size())).S);
  return pairs;
}

TEST(IsotropicStart, RodsAtModerateDensityAreApartAndIsotropic) {
  const Shape rods{.length = 5.0};
  const long long n = 500;
  const Box box = box_at_reduced_density(n, rods, 0.3);
  CompressionReport report;
  const Particles p = make_isotropic(n, rods, box, 11, {}, &report);
  expect_valid(p, n, rods, box, report);
  EXPECT_GT(report.compressions, 0);
  EXPECT_GE(report.sweeps, report.compressions);
  // Independent random axes give <S> = 0.81 / sqrt(N) = 0.036, 99.9 % below 0.079.
  EXPECT_LT(report.order_parameter, 0.1);
  EXPECT_LT(report.min_distance, 0.1);  // a dense fluid: some pair nearly touches
}

TEST(IsotropicStart, SameSeedSameBitsAtAnyThreadCountOtherSeedOtherBits) {
  const testing::ThreadCountGuard guard;
  const Shape rods{.length = 5.0};
  const long long n = 200;
  Box box;  // not cubic, rho* = 0.3
  const double side = std::cbrt(n / (0.3 * rods.close_packing_density()) / 1.5);
  box.length = {side, 1.2 * side, 1.25 * side};
  omp_set_num_threads(1);
  CompressionReport first_report, again_report;
  const Particles first = make_isotropic(n, rods, box, 5, {}, &first_report);
  omp_set_num_threads(2);
  const Particles again = make_isotropic(n, rods, box, 5, {}, &again_report);
  const Particles other = make_isotropic(n, rods, box, 6);
  for (const auto field : {&Particles::x, &Particles::y, &Particles::z, &Particles::ex,
                           &Particles::ey, &Particles::ez}) {
    EXPECT_EQ(first.*field, again.*field);
    EXPECT_NE(first.*field, other.*field);
  }
  expect_valid(first, n, rods, box, first_report);
  EXPECT_EQ(first_report.sweeps, again_report.sweeps);
  EXPECT_EQ(first_report.order_parameter, again_report.order_parameter);
  EXPECT_EQ(first_report.min_distance, again_report.min_distance);
}

TEST(IsotropicStart, HardSpheresUpToPackingFraction045) {
  const Shape spheres{.length = 0.0};
  const long long n = 500;
  for (const double eta : {0.30, 0.45}) {
    SCOPED_TRACE("eta = " + std::to_string(eta));
    const Box box = box_at_packing_fraction(n, spheres, eta);
    CompressionReport report;
    const Particles p = make_isotropic(n, spheres, box, 3, {}, &report);
    expect_valid(p, n, spheres, box, report);
    EXPECT_LT(report.min_distance, 0.05);
  }
}

TEST(IsotropicStart, OneTwoAndTenBodies) {
  const Shape rods{.length = 5.0};
  const Shape spheres{.length = 0.0};
  for (const long long n : {1LL, 2LL, 10LL}) {
    SCOPED_TRACE("n = " + std::to_string(n));
    CompressionReport report;
    const Box rod_box = cube(12.5);  // just above 2 (L + D)
    Particles p = make_isotropic(n, rods, rod_box, 2, {}, &report);
    expect_valid(p, n, rods, rod_box, report);
    // Spheres at packing fraction 0.3 where the box allows (side > 2 D), else at side 2.5.
    const Box sphere_box = cube(std::max(2.5, box_at_packing_fraction(n, spheres, 0.3).length.x));
    p = make_isotropic(n, spheres, sphere_box, 2, {}, &report);
    expect_valid(p, n, spheres, sphere_box, report);
  }
  CompressionReport report;
  make_isotropic(1, rods, cube(12.5), 2, {}, &report);
  EXPECT_NEAR(report.order_parameter, 1.0, 1e-12);  // one axis is perfectly aligned with itself
  EXPECT_EQ(report.min_distance, 1.0);              // no pair: reported as D
}

TEST(IsotropicStart, UnreachableTargetsThrowWithTheReason) {
  const Shape spheres{.length = 0.0};
  const long long n = 500;
  try {
    make_isotropic(n, spheres, box_at_packing_fraction(n, spheres, 0.8), 1);
    FAIL() << "no exception above close packing";
  } catch (const std::runtime_error &e) {
    EXPECT_NE(std::string(e.what()).find("close packing"), std::string::npos) << e.what();
  }
  CompressionOptions options;
  options.max_sweeps = 5;
  CompressionReport report;
  try {
    make_isotropic(n, spheres, box_at_packing_fraction(n, spheres, 0.45), 1, options, &report);
    FAIL() << "no exception after 5 sweeps";
  } catch (const std::runtime_error &e) {
    EXPECT_NE(std::string(e.what()).find("max_sweeps = 5"), std::string::npos) << e.what();
  }
  EXPECT_EQ(report.sweeps, 5);
  EXPECT_FALSE(report.reached);
  EXPECT_GT(report.box_scale, 1.0);
  options = {};
  options.max_seconds = 1e-9;
  try {
    make_isotropic(n, spheres, box_at_packing_fraction(n, spheres, 0.45), 1, options);
    FAIL() << "no exception after 1 ns";
  } catch (const std::runtime_error &e) {
    EXPECT_NE(std::string(e.what()).find("max_seconds"), std::string::npos) << e.what();
  }
}

TEST(IsotropicStart, BadArgumentsAreRejected) {
  const Shape rods{.length = 5.0};
  EXPECT_THROW(make_isotropic(0, rods, cube(20), 1), std::invalid_argument);
  EXPECT_THROW(make_isotropic(10, rods, cube(12), 1), std::invalid_argument);  // 2 (L + D)
  CompressionOptions options;
  options.start_packing_fraction = 0.0;
  EXPECT_THROW(make_isotropic(10, rods, cube(20), 1, options), std::invalid_argument);
}

// Timing experiment, not a test: the everyday scene's bodies (N = 2304, L/D = 5, rho* = 0.5,
// cubic box of side 28.53 D), seed 1.
TEST(IsotropicStart, DISABLED_TimingEverydayScene) {
  const Shape rods{.length = 5.0};
  const long long n = 2304;
  const Box box = box_at_reduced_density(n, rods, 0.5);
  CompressionReport report;
  const Particles p = make_isotropic(n, rods, box, 1, {}, &report);
  std::printf(
      "N = %lld, L/D = 5, rho* = 0.5, box side %.4f: %.2f s, %lld sweeps, %lld "
      "compressions, S = %.4f, min_distance = %.3g\n",
      n, box.length.x, report.seconds, report.sweeps, report.compressions, report.order_parameter,
      report.min_distance);
  expect_valid(p, n, rods, box, report);
}

}  // namespace
}  // namespace hardrod
