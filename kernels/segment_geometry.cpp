// Segment-segment closest points of two capsule axes, and the contact normal (docs/physics.md
// section 4). Reference: Ericson, Real-Time Collision Detection 5.1.9 (clamped line solution, then
// alternate clamped projections), rewritten through d = e_i -+ e_j so that no cancellation is
// divided by sin^2(theta); the body lives in the header (segment_closest_inline) so traversals
// can inline it. Inputs: r_ij, unit axes, half lengths. Pure functions, no state: thread safe.
#include "kernels/segment_geometry.hpp"

#include <algorithm>
#include <cmath>

namespace hardrod {
namespace {

// sin^2 of the axis angle below which the contact normal no longer uses e_i x e_j (1e-14 rad).
constexpr double kParallelSin2 = 1e-28;

// |gap| below which the gap direction is round-off (|gap| error ~ 1e-16 * |r_ij| <= 2e-13 D for
// L/D = 1000), so the normal falls back to the axes: 1e-10 D, i.e. |gap|^2 < 1e-20 D^2.
constexpr double kNormalMinDist2 = 1e-20;

Vec3 unit(const Vec3 &v, double len2) { return (1.0 / std::sqrt(len2)) * v; }

// A fixed axis perpendicular to e: e x (coordinate axis least aligned with e, lowest index on
// ties). Never NaN: a zero e (not a valid axis) gives z.
Vec3 fixed_perpendicular(const Vec3 &e) {
  const double ax = std::abs(e.x), ay = std::abs(e.y), az = std::abs(e.z);
  Vec3 axis{0.0, 0.0, 1.0};
  if (ax <= ay && ax <= az) {
    axis = {1.0, 0.0, 0.0};
  } else if (ay <= az) {
    axis = {0.0, 1.0, 0.0};
  }
  const Vec3 n = cross(e, axis);
  const double n2 = norm2(n);
  return n2 > 0.0 ? unit(n, n2) : Vec3{0.0, 0.0, 1.0};
}

}  // namespace

SegmentClosest segment_closest(const Vec3 &r_ij, const Vec3 &e_i, double h_i, const Vec3 &e_j,
                               double h_j) {
  return segment_closest_inline(r_ij, e_i, h_i, e_j, h_j);
}

Vec3 contact_normal(const SegmentClosest &c, const Vec3 &r_ij, const Vec3 &e_i, const Vec3 &e_j) {
  if (c.dist2 > kNormalMinDist2) return unit(c.gap, c.dist2);
  // Axes (nearly) touch: the normal of the plane of both axes, pointing away from j.
  const Vec3 f = std::copysign(1.0, dot(e_i, e_j)) * e_j;
  // e_i x f as d x e_i with d = e_i - f exact-ish: full relative accuracy at small angles,
  // where cross(e_i, f) would be round-off (error eps / theta in direction).
  const Vec3 x = cross(e_i - f, e_i);
  const double x2 = norm2(x);
  if (x2 > kParallelSin2) {
    const Vec3 n = unit(x, x2);
    return dot(n, r_ij) > 0.0 ? -n : n;
  }
  // Parallel touching axes (or a degenerate axis): push i away from j's centre, else a fixed
  // direction perpendicular to e_i (coincident bodies).
  const double r2 = norm2(r_ij);
  if (r2 > kNormalMinDist2) return -unit(r_ij, r2);
  return fixed_perpendicular(e_i);
}

}  // namespace hardrod
