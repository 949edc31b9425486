// Order tensor, director and angular histogram against exactly known orientation sets
// (perfect alignment, a uniform cone about a tilted director, a uniform plane), isotropic
// samples with statistical tolerances, and bit-identity across OpenMP thread counts and body
// orders (docs/physics.md sections 5 and 7). Random numbers: std::mt19937_64 with fixed seeds and
// hand-written transforms, so the samples are the same with every standard library.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include "kernels/order_tensor.hpp"
#include "tests/thread_count_guard.hpp"

namespace hardrod {
namespace {

double uniform01(std::mt19937_64 &rng) {
  return (static_cast<double>(rng() >> 11) + 0.5) * 0x1.0p-53;
}

Vec3 unit(const Vec3 &v) { return v * (1.0 / norm(v)); }

// Uniform on the sphere: cos(theta) uniform in [-1, 1], phi uniform.
Vec3 random_unit(std::mt19937_64 &rng) {
  const double z = 2.0 * uniform01(rng) - 1.0;
  const double phi = 2.0 * std::numbers::pi * uniform01(rng);
  const double r = std::sqrt(1.0 - z * z);
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Two unit vectors completing n to a right-handed orthonormal frame.
void complete_frame(const Vec3 &n, Vec3 &u, Vec3 &v) {
  const Vec3 helper = std::fabs(n.x) < 0.9 ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
  u = unit(cross(n, helper));
  v = cross(n, u);
}

Particles bodies_with_axes(const std::vector<Vec3> &axes) {
  Particles p;
  p.resize(axes.size());
  for (std::size_t i = 0; i < axes.size(); ++i) {
    p.id[i] = static_cast<std::int64_t>(i);
    p.set_axis(i, axes[i]);
  }
  return p;
}

std::vector<Vec3> isotropic_axes(std::size_t n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Vec3> axes(n);
  for (Vec3 &e : axes) e = random_unit(rng);
  return axes;
}

// Axes at polar angle theta about n, azimuths evenly spaced (so Q is exactly uniaxial about
// n), each with a random head-tail sign, which Q must not see.
std::vector<Vec3> cone_axes(const Vec3 &n, double theta, std::size_t count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Vec3 u, v;
  complete_frame(n, u, v);
  std::vector<Vec3> axes(count);
  for (std::size_t k = 0; k < count; ++k) {
    const double phi = 2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(count);
    const Vec3 e = std::cos(theta) * n + std::sin(theta) * (std::cos(phi) * u + std::sin(phi) * v);
    axes[k] = (rng() & 1) ? e : -e;
  }
  return axes;
}

OrderParameter order_of(const std::vector<Vec3> &axes) {
  const Particles p = bodies_with_axes(axes);
  return order_parameter(axis_moments(p, p.size()));
}

// Bit patterns, so that the comparison tells apart what == would not (-0.0 and 0.0).
std::vector<std::uint64_t> bits_of(const OrderParameter &op) {
  std::vector<double> values = {op.S, op.director.x, op.director.y, op.director.z};
  values.insert(values.end(), op.Q.begin(), op.Q.end());
  values.insert(values.end(), op.eigenvalues.begin(), op.eigenvalues.end());
  std::vector<std::uint64_t> bits(values.size());
  std::transform(values.begin(), values.end(), bits.begin(),
                 [](double v) { return std::bit_cast<std::uint64_t>(v); });
  return bits;
}

void expect_same_sums(const AxisMoments &a, const AxisMoments &b) {
  EXPECT_TRUE(a.xx.raw() == b.xx.raw() && a.xy.raw() == b.xy.raw() && a.xz.raw() == b.xz.raw() &&
              a.yy.raw() == b.yy.raw() && a.yz.raw() == b.yz.raw() && a.zz.raw() == b.zz.raw());
  EXPECT_EQ(a.count, b.count);
}

using testing::ThreadCountGuard;

TEST(OrderTensor, PerfectAlignmentGivesFullOrderAlongTheAxis) {
  for (const Vec3 &axis :
       {Vec3{1, 0, 0}, Vec3{0, 0, 1}, unit(Vec3{1, 2, 3}), unit(Vec3{-4, 1, 2})}) {
    std::vector<Vec3> axes(1000, axis);
    for (std::size_t i = 0; i < axes.size(); i += 3) axes[i] = -axis;  // head-tail symmetric
    const OrderParameter op = order_of(axes);
    EXPECT_NEAR(op.S, 1.0, 1e-13);
    EXPECT_NEAR(op.eigenvalues[0], -0.5, 1e-13);
    EXPECT_NEAR(op.eigenvalues[1], -0.5, 1e-13);
    // Sign convention: the largest |component| of the director is positive.
    const double sign =
        std::fabs(axis.x) >= std::fabs(axis.y) && std::fabs(axis.x) >= std::fabs(axis.z) ? axis.x
        : std::fabs(axis.y) >= std::fabs(axis.z)                                         ? axis.y
                                                                                         : axis.z;
    const Vec3 expected = sign > 0 ? axis : -axis;
    EXPECT_NEAR(op.director.x, expected.x, 1e-12);
    EXPECT_NEAR(op.director.y, expected.y, 1e-12);
    EXPECT_NEAR(op.director.z, expected.z, 1e-12);
  }
}

TEST(OrderTensor, IsotropicSampleHasOrderOfInverseSqrtN) {
  const OrderParameter op = order_of(isotropic_axes(100000, 11));
  // Largest eigenvalue of a traceless Q is >= 0; for N = 1e5 isotropic axes it is a few
  // 1e-3. Axes drawn uniform in theta instead of cos(theta) would give S = 0.25.
  EXPECT_GT(op.S, 0.0);
  EXPECT_LT(op.S, 0.02);
  EXPECT_GT(op.eigenvalues[0], -0.02);
}

TEST(OrderTensor, AxesUniformInAPlaneGiveMinusHalfAndTwoQuarters) {
  const Vec3 normal = unit(Vec3{1, -1, 2});
  Vec3 u, v;
  complete_frame(normal, u, v);
  std::vector<Vec3> axes(997);
  for (std::size_t k = 0; k < axes.size(); ++k) {
    const double phi =
        2.0 * std::numbers::pi * static_cast<double>(k) / static_cast<double>(axes.size());
    axes[k] = std::cos(phi) * u + std::sin(phi) * v;
  }
  const OrderParameter op = order_of(axes);
  EXPECT_NEAR(op.eigenvalues[0], -0.5, 1e-12);
  EXPECT_NEAR(op.eigenvalues[1], 0.25, 1e-12);
  EXPECT_NEAR(op.eigenvalues[2], 0.25, 1e-12);
  EXPECT_NEAR(op.S, 0.25, 1e-12);
  // Degenerate top eigenvalue: the director is some unit vector in the plane.
  EXPECT_NEAR(dot(op.director, normal), 0.0, 1e-9);
  EXPECT_NEAR(norm(op.director), 1.0, 1e-12);
  // The plane normal is the eigenvector of -1/2.
  const auto &q = op.Q;
  const Vec3 qn{q[0] * normal.x + q[1] * normal.y + q[2] * normal.z,
                q[3] * normal.x + q[4] * normal.y + q[5] * normal.z,
                q[6] * normal.x + q[7] * normal.y + q[8] * normal.z};
  EXPECT_NEAR(norm(qn + 0.5 * normal), 0.0, 1e-12);
}

TEST(OrderTensor, QIsSymmetricAndTraceless) {
  std::vector<Vec3> axes = isotropic_axes(5000, 12);
  const std::vector<Vec3> cone = cone_axes(unit(Vec3{0.2, 0.9, -0.3}), 0.4, 5000, 13);
  axes.insert(axes.end(), cone.begin(), cone.end());
  const OrderParameter op = order_of(axes);
  const auto &q = op.Q;
  EXPECT_EQ(q[1], q[3]);
  EXPECT_EQ(q[2], q[6]);
  EXPECT_EQ(q[5], q[7]);
  EXPECT_NEAR(q[0] + q[4] + q[8], 0.0, 1e-13);
  EXPECT_NEAR(op.eigenvalues[0] + op.eigenvalues[1] + op.eigenvalues[2], 0.0, 1e-13);
  EXPECT_LE(op.eigenvalues[0], op.eigenvalues[1]);
  EXPECT_LE(op.eigenvalues[1], op.eigenvalues[2]);
  EXPECT_GT(op.S, 0.2);  // half the sample is a cone with P2(cos 0.4) = 0.78
}

TEST(OrderTensor, RecoversATiltedDirector) {
  const Vec3 director = unit(Vec3{0.3, -0.5, 0.8});  // largest component positive
  const double theta = 25.0 * std::numbers::pi / 180.0;
  const double p2 = 1.5 * std::cos(theta) * std::cos(theta) - 0.5;
  for (const Vec3 &n : {director, -director}) {
    const OrderParameter op = order_of(cone_axes(n, theta, 360, 14));
    EXPECT_NEAR(op.S, p2, 1e-12);
    EXPECT_NEAR(op.eigenvalues[0], -0.5 * p2, 1e-12);
    EXPECT_NEAR(op.eigenvalues[1], -0.5 * p2, 1e-12);
    EXPECT_NEAR(op.director.x, director.x, 1e-12);
    EXPECT_NEAR(op.director.y, director.y, 1e-12);
    EXPECT_NEAR(op.director.z, director.z, 1e-12);
  }

  // A noisy nematic: Gaussian tilts of 0.3 rad about the director, random azimuths.
  std::mt19937_64 rng(15);
  Vec3 u, v;
  complete_frame(director, u, v);
  std::vector<Vec3> axes(20000);
  for (Vec3 &e : axes) {
    const double a = 0.3 * std::sqrt(-2.0 * std::log(uniform01(rng)));
    const double phi = 2.0 * std::numbers::pi * uniform01(rng);
    e = unit(director + a * (std::cos(phi) * u + std::sin(phi) * v));
    if (rng() & 1) e = -e;
  }
  const OrderParameter op = order_of(axes);
  EXPECT_GT(dot(op.director, director), std::cos(0.01));
}

TEST(OrderTensor, BitIdenticalForAnyThreadCountAndBodyOrder) {
  ThreadCountGuard guard;
  std::vector<Vec3> axes = isotropic_axes(100001, 16);
  const std::vector<Vec3> cone = cone_axes(unit(Vec3{1, 1, 0.5}), 0.6, 30001, 17);
  axes.insert(axes.end(), cone.begin(), cone.end());
  const Particles bodies = bodies_with_axes(axes);
  std::vector<Vec3> shuffled_axes = axes;
  std::shuffle(shuffled_axes.begin(), shuffled_axes.end(), std::mt19937_64(18));
  const Particles shuffled = bodies_with_axes(shuffled_axes);

  omp_set_num_threads(1);
  const AxisMoments reference = axis_moments(bodies, bodies.size());
  const OrderParameter reference_op = order_parameter(reference);
  const AngularCounts reference_counts =
      angular_counts(bodies, bodies.size(), reference_op.director, 17);
  for (int threads : {1, 2, 4}) {
    omp_set_num_threads(threads);
    for (const Particles *p : {&bodies, &shuffled}) {
      const AxisMoments m = axis_moments(*p, p->size());
      expect_same_sums(m, reference);
      EXPECT_EQ(bits_of(order_parameter(m)), bits_of(reference_op));
      EXPECT_EQ(angular_counts(*p, p->size(), reference_op.director, 17).counts,
                reference_counts.counts);
    }
  }
  // The test has teeth: plain floating-point summation does depend on the order.
  double plain = 0.0, plain_shuffled = 0.0;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    plain += axes[i].x * axes[i].y;
    plain_shuffled += shuffled_axes[i].x * shuffled_axes[i].y;
  }
  EXPECT_NE(plain, plain_shuffled);
}

TEST(OrderTensor, MomentsMergeLikeOneSum) {
  const std::vector<Vec3> axes = isotropic_axes(1000, 19);
  const Particles p = bodies_with_axes(axes);
  // The last 400 bodies, as another rank would hold them.
  const Particles tail = bodies_with_axes(std::vector<Vec3>(axes.begin() + 600, axes.end()));
  AxisMoments merged = axis_moments(p, 600);
  merged += axis_moments(tail, 400);
  expect_same_sums(merged, axis_moments(p, 1000));
  EXPECT_EQ(merged.count, 1000);
}

TEST(OrderTensor, AngularHistogramOfIsotropicSampleIsFlat) {
  const int bins = 10;
  const std::size_t n = 100000;
  const Particles p = bodies_with_axes(isotropic_axes(n, 20));
  const Vec3 director = unit(Vec3{0.1, 0.7, -0.2});
  const std::vector<double> h = angular_histogram(p, n, director, bins);
  ASSERT_EQ(h.size(), static_cast<std::size_t>(bins));
  // Per-bin count is binomial(n, 1/bins): relative standard deviation sqrt((bins-1)/n).
  const double sigma = std::sqrt((bins - 1.0) / static_cast<double>(n));
  double sum = 0.0;
  for (double value : h) {
    EXPECT_NEAR(value, 1.0, 5.0 * sigma);
    sum += value;
  }
  EXPECT_NEAR(sum, bins, 1e-12);
}

TEST(OrderTensor, AngularHistogramOfAConeIsOneBin) {
  const Vec3 director = unit(Vec3{0.3, -0.5, 0.8});
  const double theta = 0.5;  // cos = 0.8776: bin 17 of 20
  const Particles p = bodies_with_axes(cone_axes(director, theta, 500, 21));
  const std::vector<double> h = angular_histogram(p, p.size(), director, 20);
  for (std::size_t b = 0; b < h.size(); ++b) EXPECT_EQ(h[b], b == 17 ? 20.0 : 0.0) << "bin " << b;
  // Aligned axes, |e . n| = 1 up to rounding, land in the last bin.
  const Particles aligned = bodies_with_axes(std::vector<Vec3>(10, director));
  EXPECT_EQ(angular_histogram(aligned, 10, director, 4).back(), 4.0);
}

TEST(OrderTensor, EdgeCasesFailLoudly) {
  const Particles p = bodies_with_axes(isotropic_axes(10, 22));
  EXPECT_THROW(axis_moments(p, 11), std::invalid_argument);
  EXPECT_THROW(angular_counts(p, 11, Vec3{0, 0, 1}, 5), std::invalid_argument);
  EXPECT_THROW(angular_counts(p, 10, Vec3{0, 0, 1}, 0), std::invalid_argument);

  // No bodies: Q is undefined, so everything is NaN for the caller's checks to catch.
  const OrderParameter none = order_parameter(axis_moments(p, 0));
  EXPECT_TRUE(std::isnan(none.S) && std::isnan(none.director.x) && std::isnan(none.Q[0]));
  for (double value : angular_histogram(p, 0, Vec3{0, 0, 1}, 3)) EXPECT_TRUE(std::isnan(value));

  // A non-finite axis poisons the result instead of being skipped.
  Particles broken = p;
  broken.ex[4] = std::numeric_limits<double>::quiet_NaN();
  const OrderParameter poisoned = order_parameter(axis_moments(broken, broken.size()));
  EXPECT_TRUE(std::isnan(poisoned.S) && std::isnan(poisoned.eigenvalues[0]));
  const AngularCounts counts = angular_counts(broken, broken.size(), Vec3{0, 0, 1}, 3);
  EXPECT_EQ(counts.invalid, 1);
  for (double value : counts.normalised()) EXPECT_TRUE(std::isnan(value));
  // Bodies past count are not read.
  EXPECT_FALSE(std::isnan(order_parameter(axis_moments(broken, 4)).S));
}

}  // namespace
}  // namespace hardrod
