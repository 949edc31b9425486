// Closest points of two capsule axes (segment-segment distance): the narrow phase.
// Physics: two capsules of diameter D overlap iff their axis segments are closer than D
// (SPEC.md section 4). Pure function, no state, no threading concerns; called by every
// traversal. Robust for parallel / anti-parallel axes (middle of the overlap interval),
// crossing axes (d -> 0), zero-length segments (spheres) and very long segments.
#pragma once

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

SegmentClosest segment_closest(const Vec3 &r_ij, const Vec3 &e_i, double h_i, const Vec3 &e_j,
                               double h_j);

// Contact normal from j to i: gap/|gap|, or, when the axes (nearly) touch, a deterministic
// fallback: e_i x e_j normalised, oriented so that n . r_ij <= 0 (points from j to i), or,
// for parallel touching axes, a fixed axis perpendicular to e_i.
Vec3 contact_normal(const SegmentClosest &c, const Vec3 &r_ij, const Vec3 &e_i, const Vec3 &e_j);

}  // namespace hardrod
