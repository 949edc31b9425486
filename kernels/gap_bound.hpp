// The lower bound of two rods' surface gap along a fixed direction, as the exact method's
// search steps on it (contact_time.cpp explains the bound and why it is concave), and its
// cheapest use: the screen of a candidate along its closest points' own direction
// (apart_along_gap). Inline, branch free: the detection runs the screen in vector lanes over a
// batch of candidates, with the same bits as the scalar search.
#pragma once

#include <cmath>
#include <limits>

#include "kernels/segment_geometry.hpp"
#include "kernels/vec3.hpp"

namespace hardrod {

// One rod's part of the bound L(s): h (|A + C s| - |A| + K2 s^2 + K3 s^3).
struct AxisBound {
  double A = 0.0, C = 0.0, K2 = 0.0, K3 = 0.0;
  double loss(double s) const { return std::abs(A + C * s) - std::abs(A) + s * s * (K2 + K3 * s); }
  // A supergradient of -loss: any slope of a tangent from above of the concave -loss.
  double loss_slope(double s) const {
    const double lin = A + C * s;
    const double sign = lin > 0.0 ? 1.0 : (lin < 0.0 ? -1.0 : 0.0);
    return sign * C + s * (2.0 * K2 + 3.0 * K3 * s);
  }
};

inline AxisBound axis_bound(const Vec3 &n, const Vec3 &e, const Vec3 &w) {
  const double w2 = norm2(w);
  AxisBound b;
  b.A = dot(n, e);
  b.C = dot(n, cross(w, e));
  b.K2 = 0.5 * std::abs(dot(n, w) * dot(w, e) - w2 * b.A);
  b.K3 = std::abs(b.C) * w2 / 6.0;
  return b;
}

// L(s) + margin, the lower bound of gap(t + s) + margin: g0 + closing s - s^2 (q2 + q3 s)
// - h (loss_a + loss_b), concave in s >= 0 (q2, q3, K2, K3 >= 0).
struct GapBound {
  double g0 = 0.0, closing = 0.0, h = 0.0;  // g0 includes the margin
  double q2 = 0.0, q3 = 0.0;                // the turning direction's remainder (zero if fixed)
  AxisBound a, b;
  double value(double s) const {
    return g0 + s * closing - s * s * (q2 + q3 * s) - h * (a.loss(s) + b.loss(s));
  }
  double slope(double s) const {
    return closing - s * (2.0 * q2 + 3.0 * q3 * s) - h * (a.loss_slope(s) + b.loss_slope(s));
  }
};

// The first, cheapest screen of apart_in_flight (contact_time.hpp): the fixed bound along the
// closest points' own direction, unrefined, proves the pair's surfaces more than `margin` apart
// over [0, t_to] (any unit n gives a lower bound). Bodies a, b: axes e, velocities v, angular
// velocities w; r = x_b - x_a; c their closest points. False when not proven (also for
// closest points nearer than D / 2, and for non-finite input).
inline bool apart_along_gap(const Vec3 &ea, const Vec3 &va, const Vec3 &wa, const Vec3 &eb,
                            const Vec3 &vb, const Vec3 &wb, const Vec3 &r, const SegmentClosest &c,
                            double h, double D, double t_to, double margin) {
  const Vec3 n = (1.0 / std::sqrt(c.dist2)) * c.gap;
  GapBound quick;
  quick.a = axis_bound(n, ea, wa);
  quick.b = axis_bound(n, eb, wb);
  quick.h = h;
  quick.closing = dot(n, va - vb);
  quick.g0 = -dot(n, r) - h * (std::abs(quick.a.A) + std::abs(quick.b.A)) - D - margin;
  // & rather than &&, and |x| <= max for isfinite: without branches the batch vectorises.
  return (c.dist2 > 0.25 * D * D) & (quick.g0 > 0.0) & (quick.value(t_to) > 0.0) &
         (std::abs(quick.slope(t_to)) <= std::numeric_limits<double>::max());
}

}  // namespace hardrod
