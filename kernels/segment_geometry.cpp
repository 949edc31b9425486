// Segment-segment closest points of two capsule axes, and the contact normal (SPEC.md sec. 4).
// Reference: clamped line-line solution then alternate clamped projections (Ericson, Real-Time
// Collision Detection, 5.1.9), with the nearly-parallel terms rewritten through d = e_i -+ e_j
// so that no cancellation is divided by sin^2(theta). Inputs: separation r_ij, unit axes, half
// lengths; outputs: s, t, gap = p_i - p_j, |gap|^2. Pure functions, no state: thread safe.
#include "kernels/segment_geometry.hpp"

#include <algorithm>
#include <cmath>

namespace hardrod {
namespace {

// Largest tilt of axis j relative to axis i, accumulated over the shorter segment, that still
// counts as parallel: 1e-14 D. The middle of the overlap is then within 1e-14 D of the true
// distance (below the round-off of |gap|, ~1e-16 |r_ij|), and the line solution above it
// is accurate, so the switch is invisible in the distance.
constexpr double kTilt = 1e-14;

// sin^2 of the axis angle below which the contact normal no longer uses e_i x e_j (1e-14 rad).
constexpr double kParallelSin2 = 1e-28;

// |gap| below which the gap direction is round-off (|gap| error ~ 1e-16 * |r_ij| <= 2e-13 D for
// L/D = 1000), so the normal falls back to the axes: 1e-10 D, i.e. |gap|^2 < 1e-20 D^2.
constexpr double kNormalMinDist2 = 1e-20;

inline double clamp_half(double x, double h) { return std::min(std::max(x, -h), h); }

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
  // Work with f = +-e_j so that c = e_i . f >= 0; the sign flip is exact and t flips back.
  const double sign = dot(e_i, e_j) < 0.0 ? -1.0 : 1.0;
  const Vec3 f = sign * e_j;
  const double c = dot(e_i, f);
  // e_i x f = (e_i - f) x ... = d x e_i: d is nearly exact (Sterbenz) when the axes are close,
  // so the plane normal keeps full relative accuracy at small angles, where e_i x f directly
  // would be round-off. No unit-length identity is used, so |e| = 1 +- eps is harmless.
  const Vec3 n = cross(e_i - f, e_i);
  const double sin2 = norm2(n);
  const double a = dot(e_i, r_ij);  // centre of j projected on axis i
  const double b = dot(f, r_ij);    // ... and on axis j
  // Parallel when axis j tilts by less than kTilt over the shorter segment: then the distance
  // is constant over the overlap to round-off and its middle carries no torque. Always true
  // for a zero-length segment, where the middle rule reduces to the point-segment projection.
  const double h_min = std::min(h_i, h_j);
  const bool parallel = sin2 * h_min * h_min < kTilt * kTilt;
  // Line-line solution s* = ((r x f) . n) / |n|^2: numerator O(theta |r|) with error
  // O(eps theta |r|), so s* is off by O(eps |r| / theta) along a valley of curvature theta^2:
  // |gap|^2 is off by O(eps^2 |r|^2), uniformly in theta.
  const double s_line = dot(cross(r_ij, f), n) / (parallel ? 1.0 : sin2);
  // Parallel: middle of the overlap of [-h_i, h_i] with j projected on i ([a -+ h_j]); with
  // no overlap the clamp gives the nearest end.
  const double s_mid = 0.5 * (std::max(-h_i, a - h_j) + std::min(h_i, a + h_j));
  const double s0 = clamp_half(parallel ? s_mid : s_line, h_i);
  // Best t for s0, clamped; then best s for that t, clamped (Ericson's order, branch free).
  const double tf = clamp_half(s0 * c - b, h_j);
  const double s = parallel ? s0 : clamp_half(a + tf * c, h_i);

  SegmentClosest out;
  out.s = s;
  out.t = sign * tf;
  out.gap = (s * e_i - r_ij) - tf * f;
  out.dist2 = norm2(out.gap);
  return out;
}

Vec3 contact_normal(const SegmentClosest &c, const Vec3 &r_ij, const Vec3 &e_i, const Vec3 &e_j) {
  if (c.dist2 > kNormalMinDist2) return unit(c.gap, c.dist2);
  // Axes (nearly) touch: the normal of the plane of both axes, pointing away from j.
  const Vec3 f = dot(e_i, e_j) < 0.0 ? -e_j : e_j;
  const Vec3 x = cross(e_i - f, e_i);  // e_i x f, accurate at small angles (see above)
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
