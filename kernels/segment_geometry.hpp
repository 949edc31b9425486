// Closest points of two capsule axes (segment-segment distance): the narrow phase.
// Physics: two capsules of diameter D overlap iff their axis segments are closer than D
// (docs/physics.md section 4). Pure function, no state, no threading concerns; called by every
// traversal. Robust for parallel / anti-parallel axes (middle of the overlap interval),
// crossing axes (d -> 0), zero-length segments (spheres) and very long segments.
// Reference: Ericson, Real-Time Collision Detection (2005) 5.1.9, made robust at small angles.
#pragma once

#include <algorithm>
#include <cmath>

#include "kernels/vec3.hpp"

namespace hardrod {

// Segment i: centre 0 (the caller passes the separation), unit axis e_i, half length h_i.
// Segment j: centre r_ij = x_j - x_i (already minimum-imaged), unit axis e_j, half length h_j.
struct SegmentClosest {
  double s = 0.0;      // closest point on i: p_i = x_i + s e_i, s in [-h_i, h_i]
  double t = 0.0;      // closest point on j: p_j = x_j + t e_j, t in [-h_j, h_j]
  Vec3 gap;            // p_i - p_j (points from j to i)
  double dist2 = 0.0;  // |gap|^2
};

// Accuracy: |gap| is within a few eps * max(|r_ij|, h_i, h_j) of the exact distance, at every
// angle. Parallel axes (tilt over the shorter segment < 1e-14 D) take the middle of the overlap
// of the projections, or the nearest ends if they do not overlap. Swapping i and j
// (r_ij -> -r_ij) gives the same distance and swapped s, t up to round-off (the two orders
// round differently; where the minimiser is not unique the middle rule picks the same point).
// Never NaN for finite inputs; no state, so the same inputs give the same bits.
SegmentClosest segment_closest(const Vec3 &r_ij, const Vec3 &e_i, double h_i, const Vec3 &e_j,
                               double h_j);

// Contact normal from j to i: gap/|gap| if |gap| > 1e-10 D; else (axes touch: the direction
// is round-off) e_i x e_j normalised, oriented so that n . r_ij <= 0; else (parallel axes too)
// -r_ij normalised; else (coincident bodies) e_i x (coordinate axis least aligned with e_i).
Vec3 contact_normal(const SegmentClosest &c, const Vec3 &r_ij, const Vec3 &e_i, const Vec3 &e_j);

// The body of segment_closest, visible to hot traversals so it inlines (bench_segment_geometry
// compares the two), the more so where the caller reads only some fields (e.g. dist2).
// Bit-identical to segment_closest when compiled with the project's flags (no FMA
// contraction, no fast-math); InlineAndOutOfLineAreBitIdentical checks it.
inline SegmentClosest segment_closest_inline(const Vec3 &r_ij, const Vec3 &e_i, double h_i,
                                             const Vec3 &e_j, double h_j) {
  // Largest tilt of axis j against axis i, over the shorter segment, that counts as parallel.
  constexpr double kTilt = 1e-14;
  auto clamp_half = [](double x, double h) { return std::min(std::max(x, -h), h); };
  // Work with f = +-e_j so that c = e_i . f >= 0; the flip is exact and t flips back. A
  // copysign, not a branch: nematic neighbours are anti-parallel half the time, at random.
  const double c_signed = dot(e_i, e_j);
  const double sign = std::copysign(1.0, c_signed);
  const Vec3 f = sign * e_j;
  const double c = sign * c_signed;
  // d = e_i - f is exact-ish (Sterbenz) for close axes, so sin^2 = |d|^2 (1 - |d|^2/4) keeps
  // full relative accuracy at small angles, where 1 - c^2 would be pure round-off. (This
  // identity assumes unit axes; |e| = 1 +- eps changes sin^2 by a relative O(eps) only.)
  const Vec3 d = e_i - f;
  const double d2 = norm2(d);
  const double sin2 = d2 * (1.0 - 0.25 * d2);
  const double a = dot(e_i, r_ij);         // centre of j projected on axis i
  const double b = sign * dot(e_j, r_ij);  // ... and on axis j (= f . r_ij)
  // Parallel: the distance is constant over the overlap to within kTilt, and its middle exerts
  // no torque. Always so for a zero-length segment: the middle rule is then point-segment.
  const double h_min = std::min(h_i, h_j);
  const bool parallel = sin2 * h_min * h_min < kTilt * kTilt;
  // Line-line solution s* = ((r x f) . (e_i x f)) / |e_i x f|^2, the numerator by
  // Binet-Cauchy with e_i x f = d x e_i: (d . r)(f . e_i) - (e_i . r)(f . d). Its error is
  // O(eps theta |r|), so s* is off by O(eps |r| / theta) along a valley of curvature
  // theta^2 and |gap|^2 by O(eps^2 |r|^2), uniformly in theta. The numerator is exact for
  // the given vectors: the naive a - b c would be off by eps |r| (norm round-off included).
  const double s_line = (dot(d, r_ij) * c - a * dot(f, d)) / (parallel ? 1.0 : sin2);
  // Middle of the overlap of [-h_i, h_i] with j projected on i, [a - h_j, a + h_j]; without
  // overlap the clamp below gives the nearest end.
  const double s_mid = 0.5 * (std::max(-h_i, a - h_j) + std::min(h_i, a + h_j));
  const double s0 = clamp_half(parallel ? s_mid : s_line, h_i);
  // Best t for s0, clamped; then best s for that t, clamped (Ericson's order, branch free).
  const double t_f = clamp_half(s0 * c - b, h_j);
  const double s = parallel ? s0 : clamp_half(a + t_f * c, h_i);

  SegmentClosest out;
  out.s = s;
  out.t = sign * t_f;
  out.gap = s * e_i - (r_ij + t_f * f);
  out.dist2 = norm2(out.gap);
  return out;
}

}  // namespace hardrod
