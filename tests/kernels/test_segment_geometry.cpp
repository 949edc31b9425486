// Tests of the narrow-phase kernel (segment_closest, contact_normal) against brute force.
// Reference: golden-section minimisation, in long double, of the reduced distance
// g(s) = min_t |s e_i - r - t e_j|^2 (convex in s; the inner minimum is a clamped projection),
// so it shares no formula with the kernel. Randomised with fixed seeds over all extremes:
// parallel, anti-parallel, nearly parallel, crossing, zero length, h = 500, |r| = 1e6.
// Serial; each test owns its generator.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <sstream>
#include <string>

#include "kernels/segment_geometry.hpp"

namespace hardrod {
namespace {

using LD = long double;

// Distances must match to 1e-12 relative to max(d, D), D = 1: the contact scale.
constexpr double kDistTol = 1e-12;

struct Pair {
  Vec3 r, e_i, e_j;
  double h_i = 0.0, h_j = 0.0;
};

std::string describe(const Pair &p) {
  std::ostringstream os;
  os.precision(17);
  os << "r=(" << p.r.x << "," << p.r.y << "," << p.r.z << ") e_i=(" << p.e_i.x << "," << p.e_i.y
     << "," << p.e_i.z << ") h_i=" << p.h_i << " e_j=(" << p.e_j.x << "," << p.e_j.y << ","
     << p.e_j.z << ") h_j=" << p.h_j;
  return os.str();
}

std::string sci(double v) {
  std::ostringstream os;
  os.precision(3);
  os << std::scientific << v;
  return os.str();
}

struct Reference {
  LD dist2 = 0, s = 0, t = 0;
};

// Exact for the given (not renormalised) double vectors, up to long double round-off.
Reference brute_force(const Pair &p) {
  const std::array<LD, 3> r{p.r.x, p.r.y, p.r.z}, ei{p.e_i.x, p.e_i.y, p.e_i.z},
      ej{p.e_j.x, p.e_j.y, p.e_j.z};
  const LD ej2 = ej[0] * ej[0] + ej[1] * ej[1] + ej[2] * ej[2];
  auto eval = [&](LD s) {
    std::array<LD, 3> q{};
    LD proj = 0;
    for (int k = 0; k < 3; ++k) {
      q[k] = s * ei[k] - r[k];
      proj += q[k] * ej[k];
    }
    const LD t = ej2 > 0 ? std::clamp(proj / ej2, LD(-p.h_j), LD(p.h_j)) : LD(0);
    LD d2 = 0;
    for (int k = 0; k < 3; ++k) d2 += (q[k] - t * ej[k]) * (q[k] - t * ej[k]);
    return Reference{d2, s, t};
  };
  const LD inv_phi = (std::sqrt(LD(5)) - 1) / 2;
  LD lo = -p.h_i, hi = p.h_i;
  LD x1 = hi - inv_phi * (hi - lo), x2 = lo + inv_phi * (hi - lo);
  Reference f1 = eval(x1), f2 = eval(x2);
  for (int it = 0; it < 160 && hi > lo; ++it) {
    if (f1.dist2 <= f2.dist2) {
      hi = x2, x2 = x1, f2 = f1, x1 = hi - inv_phi * (hi - lo), f1 = eval(x1);
    } else {
      lo = x1, x1 = x2, f1 = f2, x2 = lo + inv_phi * (hi - lo), f2 = eval(x2);
    }
  }
  Reference best = f1;
  for (const Reference &c : {f2, eval(LD(-p.h_i)), eval(LD(p.h_i))}) {
    if (c.dist2 < best.dist2) best = c;
  }
  return best;
}

SegmentClosest closest(const Pair &p) { return segment_closest(p.r, p.e_i, p.h_i, p.e_j, p.h_j); }
SegmentClosest closest_swapped(const Pair &p) {
  return segment_closest(-p.r, p.e_j, p.h_j, p.e_i, p.h_i);
}

bool finite(const SegmentClosest &c) {
  return std::isfinite(c.s) && std::isfinite(c.t) && std::isfinite(c.dist2) &&
         std::isfinite(c.gap.x) && std::isfinite(c.gap.y) && std::isfinite(c.gap.z);
}

// Checks one pair against the reference and the kernel's own contract; returns the number of
// violated properties (details go to the test log for the first failures only).
int check_against_reference(const Pair &p, int &reported) {
  const SegmentClosest c = closest(p);
  const Reference ref = brute_force(p);
  const double d = std::sqrt(c.dist2), d_ref = std::sqrt(double(ref.dist2));
  const Vec3 gap = (c.s * p.e_i) - (p.r + c.t * p.e_j);
  const double scale = std::max({1.0, norm(p.r), p.h_i, p.h_j});
  int bad = 0;
  std::string what;
  auto fail = [&](const std::string &msg) { ++bad, what += msg + "; "; };
  if (!finite(c)) fail("non-finite result");
  if (!(std::abs(c.s) <= p.h_i) || !(std::abs(c.t) <= p.h_j)) fail("s or t out of bounds");
  if (!(std::abs(d - d_ref) <= kDistTol * std::max(d_ref, 1.0)))
    fail("distance off by " + sci(d - d_ref) + " from reference " + sci(d_ref));
  if (!(norm(gap - c.gap) <= 4e-16 * scale)) fail("gap is not s e_i - r - t e_j");
  if (!(std::abs(c.dist2 - norm2(c.gap)) <= 4e-16 * c.dist2)) fail("dist2 is not |gap|^2");
  if (bad > 0 && reported++ < 5) ADD_FAILURE() << what << "\n  " << describe(p);
  return bad;
}

// a x b to full relative accuracy even for nearly parallel a, b: each product is split exactly
// (a b = p + fma(a, b, -p)) and the differences are taken in long double.
Vec3 accurate_cross(const Vec3 &a, const Vec3 &b) {
  auto diff_of_products = [](double w, double x, double y, double z) {
    const double p = w * x, q = y * z;
    return double((LD(p) - LD(q)) + (LD(std::fma(w, x, -p)) - LD(std::fma(y, z, -q))));
  };
  return {diff_of_products(a.y, b.z, a.z, b.y), diff_of_products(a.z, b.x, a.x, b.z),
          diff_of_products(a.x, b.y, a.y, b.x)};
}

// Random unit vector, uniform on the sphere.
Vec3 random_unit(std::mt19937_64 &rng) {
  std::normal_distribution<double> g;
  for (;;) {
    const Vec3 v{g(rng), g(rng), g(rng)};
    const double n2 = norm2(v);
    if (n2 > 1e-6) return (1.0 / std::sqrt(n2)) * v;
  }
}

// Unit vector at angle theta from unit e, in a random plane.
Vec3 tilted(const Vec3 &e, double theta, std::mt19937_64 &rng) {
  Vec3 u = cross(e, random_unit(rng));
  u = (1.0 / norm(u)) * u;
  return std::cos(theta) * e + std::sin(theta) * u;
}

double uniform(std::mt19937_64 &rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

// Separation with j's centre slid along axis i by up to the overlap length and offset
// sideways by up to `side`: the configurations where (nearly) parallel rods touch.
Vec3 side_by_side(const Vec3 &e_i, double h_i, double h_j, double side, std::mt19937_64 &rng) {
  const double along = uniform(rng, -1.1, 1.1) * (h_i + h_j);
  Vec3 perp = cross(e_i, random_unit(rng));
  perp = (1.0 / norm(perp)) * perp;
  return along * e_i + uniform(rng, 0.0, side) * perp;
}

double random_half_length(std::mt19937_64 &rng) {
  switch (rng() % 4) {
    case 0:
      return 2.5;
    case 1:
      return 500.0;
    case 2:
      return 0.0;
    default:
      return uniform(rng, 0.0, 5.0);
  }
}

TEST(SegmentGeometry, GenericPairsMatchBruteForce) {
  std::mt19937_64 rng(0x5e9a11);
  int failures = 0, reported = 0;
  for (int n = 0; n < 4000; ++n) {
    Pair p{uniform(rng, 0.0, 8.0) * random_unit(rng), random_unit(rng), random_unit(rng),
           uniform(rng, 0.0, 3.0), uniform(rng, 0.0, 3.0)};
    failures += check_against_reference(p, reported);
  }
  EXPECT_EQ(failures, 0);
}

TEST(SegmentGeometry, ParallelAndAntiParallelTakeMiddleOfOverlap) {
  std::mt19937_64 rng(0xa11e1);
  int failures = 0, reported = 0, overlapping = 0;
  for (int n = 0; n < 3000; ++n) {
    const Vec3 e = random_unit(rng);
    const double sigma = (n % 2 == 0) ? 1.0 : -1.0;  // parallel / anti-parallel, exactly
    Pair p{{}, e, sigma * e, random_half_length(rng), random_half_length(rng)};
    p.r = side_by_side(e, p.h_i, p.h_j, 2.0, rng);
    failures += check_against_reference(p, reported);
    // Expected: middle of [-h_i, h_i] n [a - h_j, a + h_j], else the nearest ends.
    const LD a = LD(e.x) * p.r.x + LD(e.y) * p.r.y + LD(e.z) * p.r.z;
    const LD lo = std::max(LD(-p.h_i), a - p.h_j), hi = std::min(LD(p.h_i), a + p.h_j);
    overlapping += lo <= hi;
    const LD s = std::clamp((lo + hi) / 2, LD(-p.h_i), LD(p.h_i));
    const LD t = std::clamp(sigma * (s - a), LD(-p.h_j), LD(p.h_j));
    const SegmentClosest c = closest(p);
    const double tol = 1e-13 * std::max({1.0, p.h_i, p.h_j});
    if (!(std::abs(c.s - double(s)) <= tol) || !(std::abs(c.t - double(t)) <= tol)) {
      ++failures;
      if (reported++ < 5)
        ADD_FAILURE() << "not the middle: s=" << c.s << " want " << double(s) << ", t=" << c.t
                      << " want " << double(t) << "\n  " << describe(p);
    }
  }
  EXPECT_EQ(failures, 0);
  EXPECT_GT(overlapping, 1500);  // the rule is exercised, not only the nearest-end branch
}

TEST(SegmentGeometry, NearlyParallelMatchesBruteForce) {
  std::mt19937_64 rng(0x9a7a);
  int failures = 0, reported = 0;
  for (int n = 0; n < 4000; ++n) {
    const Vec3 e = random_unit(rng);
    const double theta = std::pow(10.0, uniform(rng, -16.0, -3.0));  // spans the threshold
    Pair p{{}, e, tilted(e, theta, rng), random_half_length(rng), random_half_length(rng)};
    if (n % 2 == 1) p.e_j = -p.e_j;
    p.r = side_by_side(e, p.h_i, p.h_j, 1.5, rng);
    failures += check_against_reference(p, reported);
  }
  EXPECT_EQ(failures, 0);
}

// Nearly parallel lines whose closest approach lies inside both segments: the line-line
// solution is ill conditioned in s (valley of curvature theta^2), yet the distance must not be.
TEST(SegmentGeometry, NearlyParallelInteriorApproachMatchesBruteForce) {
  std::mt19937_64 rng(0x1a7e);
  int failures = 0, reported = 0;
  for (int n = 0; n < 3000; ++n) {
    const Vec3 e_i = random_unit(rng);
    Vec3 u = cross(e_i, random_unit(rng));
    u = (1.0 / norm(u)) * u;
    const double theta = std::pow(10.0, uniform(rng, -12.0, -2.0));
    const Vec3 e_j = std::cos(theta) * e_i + std::sin(theta) * u;
    Vec3 m = cross(e_i, u);  // perpendicular to both axes
    m = (1.0 / norm(m)) * m;
    const double h = (n % 2 == 0) ? 500.0 : 2.5;
    const double s0 = uniform(rng, -h, h), t0 = uniform(rng, -h, h);
    Pair p{s0 * e_i - t0 * e_j + uniform(rng, 0.0, 1.5) * m, e_i, e_j, h, h};
    if (n % 4 >= 2) p.e_j = -p.e_j;
    failures += check_against_reference(p, reported);
  }
  EXPECT_EQ(failures, 0);
}

// Below the parallel threshold the middle rule still holds (no torque from round-off), while
// at 1e-3 rad the physical answer is an end of the overlap.
TEST(SegmentGeometry, TinyTiltKeepsMiddleButVisibleTiltPicksAnEnd) {
  const Vec3 e{1.0, 0.0, 0.0};
  const Vec3 r{1.0, 0.0, 1.0};  // j shifted by 1 along the axis, 1 to the side
  const double h = 2.5;
  std::mt19937_64 rng(7);
  const SegmentClosest tiny = segment_closest(r, e, h, tilted(e, 1e-15, rng), h);
  EXPECT_NEAR(tiny.s, 0.5 * (1.0 - h + h), 1e-9);  // overlap [-1.5, 2.5] -> middle 0.5
  EXPECT_NEAR(tiny.t, -0.5, 1e-9);
  const Vec3 e_j{std::cos(1e-3), 0.0, std::sin(1e-3)};  // tips towards i at its -t end
  const SegmentClosest tilt = segment_closest(r, e, h, e_j, h);
  EXPECT_NEAR(tilt.t, -h, 1e-12);
  EXPECT_NEAR(tilt.s, 1.0 - h * std::cos(1e-3), 1e-12);
}

TEST(SegmentGeometry, CrossingAxesGiveZeroDistanceAtTheCrossing) {
  std::mt19937_64 rng(0xc055);
  int failures = 0, reported = 0;
  for (int n = 0; n < 2000; ++n) {
    const Vec3 e_i = random_unit(rng), e_j = random_unit(rng);
    if (norm2(cross(e_i, e_j)) < 1e-2) continue;  // the crossing point is well conditioned
    const double h_i = (n % 3 == 0) ? 500.0 : 2.5, h_j = (n % 5 == 0) ? 500.0 : 2.5;
    const double s0 = uniform(rng, -h_i, h_i), t0 = uniform(rng, -h_j, h_j);
    const Pair p{s0 * e_i - t0 * e_j, e_i, e_j, h_i, h_j};
    failures += check_against_reference(p, reported);
    const SegmentClosest c = closest(p);
    const double scale = std::max(h_i, h_j);
    if (!(std::sqrt(c.dist2) <= 1e-14 * scale) || !(std::abs(c.s - s0) <= 1e-12 * scale) ||
        !(std::abs(c.t - t0) <= 1e-12 * scale)) {
      ++failures;
      if (reported++ < 5)
        ADD_FAILURE() << "crossing missed: d=" << std::sqrt(c.dist2) << " s-s0=" << c.s - s0
                      << " t-t0=" << c.t - t0 << "\n  " << describe(p);
    }
  }
  EXPECT_EQ(failures, 0);
}

TEST(SegmentGeometry, ZeroLengthSegmentsArePointSegmentAndPointPoint) {
  std::mt19937_64 rng(0x5fe4e);
  int failures = 0, reported = 0;
  for (int n = 0; n < 3000; ++n) {
    const Vec3 e_i = random_unit(rng);
    const Vec3 e_j = (n % 7 == 0) ? e_i : random_unit(rng);
    const double h_long = (n % 2 == 0) ? 500.0 : 2.5;
    Pair p{uniform(rng, 0.0, 6.0) * random_unit(rng), e_i, e_j, 0.0, 0.0};
    if (n % 3 == 0) p.h_i = h_long;
    if (n % 3 == 1) p.h_j = h_long;
    failures += check_against_reference(p, reported);
    const SegmentClosest c = closest(p);
    if (p.h_i == 0.0 && p.h_j == 0.0) {  // spheres: exactly the centre distance
      EXPECT_EQ(c.dist2, norm2(p.r));
      EXPECT_EQ(c.s, 0.0);
      EXPECT_EQ(c.t, 0.0);
    }
  }
  EXPECT_EQ(failures, 0);
}

TEST(SegmentGeometry, VeryLongRodsAndLargeSeparations) {
  std::mt19937_64 rng(0x10ff);
  int failures = 0, reported = 0;
  for (int n = 0; n < 3000; ++n) {
    const Vec3 e_i = random_unit(rng);
    const Vec3 e_j = (n % 4 == 0) ? tilted(e_i, uniform(rng, 0.0, 0.3), rng) : random_unit(rng);
    Pair p{{}, e_i, e_j, 500.0, (n % 2 == 0) ? 500.0 : random_half_length(rng)};
    p.r = (n % 3 == 0) ? uniform(rng, 0.5e6, 2e6) * random_unit(rng)
                       : side_by_side(e_i, p.h_i, p.h_j, 3.0, rng) +
                             uniform(rng, -3.0, 3.0) * random_unit(rng);
    failures += check_against_reference(p, reported);
  }
  EXPECT_EQ(failures, 0);
}

// Swapping i and j (r -> -r) gives the same distance and swapped s, t. The two orders round
// differently, so this holds to round-off; for exactly parallel axes the middle rule is exact.
TEST(SegmentGeometry, SwappingIAndJSwapsSAndT) {
  std::mt19937_64 rng(0x5a4b);
  int failures = 0, reported = 0;
  for (int n = 0; n < 4000; ++n) {
    const Vec3 e_i = random_unit(rng);
    Vec3 e_j = random_unit(rng);
    if (n % 4 == 1) e_j = -e_i;
    if (n % 4 == 2) e_j = tilted(e_i, std::pow(10.0, uniform(rng, -9.0, -3.0)), rng);
    Pair p{{}, e_i, e_j, random_half_length(rng), random_half_length(rng)};
    p.r = (n % 2 == 0) ? side_by_side(e_i, p.h_i, p.h_j, 2.0, rng)
                       : uniform(rng, 0.0, 8.0) * random_unit(rng);
    const SegmentClosest c = closest(p), w = closest_swapped(p);
    const double d = std::sqrt(c.dist2), dw = std::sqrt(w.dist2);
    const double scale = std::max({1.0, p.h_i, p.h_j, norm(p.r)});
    // s and t are only determined when the axes are not nearly parallel, or are exactly so.
    const double sin2 = norm2(cross(e_i, e_j));
    const bool determined = sin2 > 1e-2 || sin2 == 0.0;
    const bool ok = std::abs(d - dw) <= kDistTol * std::max(d, 1.0) &&
                    (!determined || (std::abs(c.s - w.t) <= 1e-12 * scale / std::max(sin2, 1e-2) &&
                                     std::abs(c.t - w.s) <= 1e-12 * scale / std::max(sin2, 1e-2)));
    if (!ok) {
      ++failures;
      if (reported++ < 5)
        ADD_FAILURE() << "asymmetric: d-dw=" << d - dw << " s=" << c.s << " vs " << w.t
                      << " t=" << c.t << " vs " << w.s << "\n  " << describe(p);
    }
  }
  EXPECT_EQ(failures, 0);
}

// The inline body and the out-of-line call must give the same bits: no FMA contraction or
// other flag difference between the header's instantiation here and the library's.
TEST(SegmentGeometry, InlineAndOutOfLineAreBitIdentical) {
  std::mt19937_64 rng(0xb175);
  int differ = 0;
  for (int n = 0; n < 4000; ++n) {
    const Vec3 e_i = random_unit(rng);
    const Vec3 e_j = (n % 3 == 0) ? tilted(e_i, std::pow(10.0, uniform(rng, -12.0, -1.0)), rng)
                                  : random_unit(rng);
    const Pair p{uniform(rng, 0.0, 8.0) * random_unit(rng), e_i, e_j, random_half_length(rng),
                 random_half_length(rng)};
    const SegmentClosest c = closest(p);
    const SegmentClosest w = segment_closest_inline(p.r, p.e_i, p.h_i, p.e_j, p.h_j);
    const std::array<double, 6> x{c.s, c.t, c.gap.x, c.gap.y, c.gap.z, c.dist2};
    const std::array<double, 6> y{w.s, w.t, w.gap.x, w.gap.y, w.gap.z, w.dist2};
    for (std::size_t k = 0; k < x.size(); ++k) {  // bits, so -0.0 != 0.0 counts too
      differ += std::bit_cast<std::uint64_t>(x[k]) != std::bit_cast<std::uint64_t>(y[k]);
    }
  }
  EXPECT_EQ(differ, 0);
}

TEST(SegmentGeometry, ContactNormalIsTheUnitGapWhenApart) {
  std::mt19937_64 rng(0x4042);
  for (int n = 0; n < 1000; ++n) {
    const Pair p{uniform(rng, 0.5, 6.0) * random_unit(rng), random_unit(rng), random_unit(rng), 2.5,
                 2.5};
    const SegmentClosest c = closest(p);
    if (c.dist2 < 1e-6) continue;
    const Vec3 nrm = contact_normal(c, p.r, p.e_i, p.e_j);
    EXPECT_NEAR(norm(nrm), 1.0, 1e-15);
    EXPECT_NEAR(dot(nrm, c.gap), std::sqrt(c.dist2), 1e-13 * std::sqrt(c.dist2));
  }
}

TEST(SegmentGeometry, ContactNormalForCrossingAxesIsPerpendicularAndAwayFromJ) {
  std::mt19937_64 rng(0xc4055);
  for (int n = 0; n < 2000; ++n) {
    // Axes at a generic angle, or nearly (anti-)parallel down to 1e-13 rad: the normal of
    // their plane must stay accurate, not turn into round-off of e_i x e_j.
    const Vec3 e_i = random_unit(rng);
    Vec3 u = cross(e_i, random_unit(rng));
    u = (1.0 / norm(u)) * u;
    const double theta =
        (n % 2 == 0) ? uniform(rng, 0.01, 3.13) : std::pow(10.0, uniform(rng, -13.0, -4.0));
    const Vec3 e_j = ((n % 4 == 3) ? -1.0 : 1.0) * (std::cos(theta) * e_i + std::sin(theta) * u);
    Vec3 m = cross(e_i, u);  // plane normal up to the rounding of e_j (eps / theta)
    m = (1.0 / norm(m)) * m;
    Vec3 m_exact = accurate_cross(e_i, e_j);  // the plane normal of e_i, e_j as given
    m_exact = (1.0 / norm(m_exact)) * m_exact;
    // j crosses i, or passes 1e-11 D above or below: below the gap threshold, so the normal
    // comes from the axes, and it must still point from j to i (along the tiny gap).
    const double lift = (n % 3 == 0) ? 0.0 : ((n % 3 == 1) ? 1e-11 : -1e-11);
    const Vec3 r = uniform(rng, -2.5, 2.5) * e_i - uniform(rng, -2.5, 2.5) * e_j + lift * m;
    const SegmentClosest c = segment_closest(r, e_i, 2.5, e_j, 2.5);
    ASSERT_LT(c.dist2, 1e-20) << describe({r, e_i, e_j, 2.5, 2.5});
    const Vec3 nrm = contact_normal(c, r, e_i, e_j);
    EXPECT_NEAR(norm(nrm), 1.0, 1e-15);
    const Vec3 m_signed = dot(nrm, m_exact) < 0.0 ? -m_exact : m_exact;
    EXPECT_LE(norm(nrm - m_signed), 1e-14) << "theta " << theta;
    EXPECT_LE(dot(nrm, r), 1e-15 * norm(r));  // exactly <= 0 in the kernel's own rounding
    if (lift != 0.0) {
      EXPECT_EQ(dot(nrm, m) > 0.0, lift < 0.0);
    }
    // Lifting j off i along -n must give a gap along +n: the fallback continues the gap rule.
    const Vec3 r_off = r - 1e-3 * nrm;
    const SegmentClosest off = segment_closest(r_off, e_i, 2.5, e_j, 2.5);
    EXPECT_GT(dot(contact_normal(off, r_off, e_i, e_j), nrm), 1.0 - 1e-9);
  }
}

TEST(SegmentGeometry, ContactNormalFallbacksForParallelAndCoincidentBodies) {
  // Parallel touching axes (collinear, overlapping): away from j's centre.
  const Vec3 x{1.0, 0.0, 0.0}, y{0.0, 1.0, 0.0}, z{0.0, 0.0, 1.0};
  const Vec3 r{1.0, 0.0, 0.0};
  Vec3 n = contact_normal(segment_closest(r, x, 2.5, x, 2.5), r, x, x);
  EXPECT_EQ(n.x, -1.0);
  EXPECT_EQ(n.y, 0.0);
  EXPECT_EQ(n.z, 0.0);
  n = contact_normal(segment_closest(r, x, 2.5, -x, 2.5), r, x, -x);
  EXPECT_EQ(n.x, -1.0);
  // Coincident: e_i x (least aligned axis): x -> x cross y = z, y -> y cross x = -z, z -> z x x.
  const Vec3 zero{};
  const std::array<std::array<Vec3, 2>, 3> cases{{{x, z}, {y, -z}, {z, y}}};
  for (const auto &[e, want] : cases) {
    n = contact_normal(segment_closest(zero, e, 2.5, e, 2.5), zero, e, e);
    EXPECT_EQ(n.x, want.x);
    EXPECT_EQ(n.y, want.y);
    EXPECT_EQ(n.z, want.z);
  }
  // Coincident spheres along random axes: still a unit vector perpendicular to e_i.
  std::mt19937_64 rng(3);
  for (int k = 0; k < 100; ++k) {
    const Vec3 e = random_unit(rng);
    n = contact_normal(segment_closest(zero, e, 0.0, e, 0.0), zero, e, e);
    EXPECT_NEAR(norm(n), 1.0, 1e-15);
    EXPECT_NEAR(dot(n, e), 0.0, 1e-15);
  }
}

TEST(SegmentGeometry, NeverNaNAtDegenerateInputs) {
  const Vec3 zero{}, x{1.0, 0.0, 0.0}, y{0.0, 1.0, 0.0};
  const std::array<Vec3, 4> rs{zero, x, Vec3{0.0, 1e-300, 0.0}, Vec3{1e150, -1e150, 3e149}};
  const std::array<Vec3, 4> axes{x, -x, y, zero};  // zero axis: not valid, must not poison
  const std::array<double, 4> hs{0.0, 1e-300, 2.5, 500.0};
  int non_finite = 0;
  for (const Vec3 &r : rs)
    for (const Vec3 &e_i : axes)
      for (const Vec3 &e_j : axes)
        for (double h_i : hs)
          for (double h_j : hs) {
            const SegmentClosest c = segment_closest(r, e_i, h_i, e_j, h_j);
            const Vec3 nrm = contact_normal(c, r, e_i, e_j);
            non_finite +=
                !finite(c) || !std::isfinite(norm2(nrm)) || std::abs(norm(nrm) - 1) > 1e-15;
          }
  EXPECT_EQ(non_finite, 0);
}

}  // namespace
}  // namespace hardrod
