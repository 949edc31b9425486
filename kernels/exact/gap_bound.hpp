// The lower bound of two rods' surface gap along a fixed direction, as the exact method's
// search steps on it (contact_time.cpp explains the bound and why it is concave), and its two
// screens of a candidate: along its closest points' own direction (apart_along_gap), and along
// normals that turn with the bodies (apart_turning). Inline, branch free: the detection runs
// them in vector lanes over a batch of candidates, with the same bits as apart_in_flight.
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "kernels/segment_geometry.hpp"
#include "kernels/vec3.hpp"

namespace hardrod {

// x where `keep`, else +0.0: a mask of x's bits rather than a select, as GCC 12 vectorises a
// choice between doubles on a comparison of doubles, not on a flag made of several (`&`).
[[gnu::always_inline]] inline double kept_or_zero(bool keep, double x) {
  return std::bit_cast<double>(std::bit_cast<std::uint64_t>(x) & (std::uint64_t{0} - keep));
}

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
// closest points nearer than D / 2, and for non-finite input). `proven`: where proven, the
// bound's least value on [0, t_to] (a concave function's: at an end), so that the surface gap
// less `margin` stays above it all that time; else 0. (The one queue keeps a pair apart with it
// after a body's velocity changes, exact_queue.cpp.)
[[gnu::always_inline]] inline bool apart_along_gap(const Vec3 &ea, const Vec3 &va, const Vec3 &wa,
                                                   const Vec3 &eb, const Vec3 &vb, const Vec3 &wb,
                                                   const Vec3 &r, const SegmentClosest &c, double h,
                                                   double D, double t_to, double margin,
                                                   double &proven) {
  const Vec3 n = (1.0 / std::sqrt(c.dist2)) * c.gap;
  GapBound quick;
  quick.a = axis_bound(n, ea, wa);
  quick.b = axis_bound(n, eb, wb);
  quick.h = h;
  quick.closing = dot(n, va - vb);
  quick.g0 = -dot(n, r) - h * (std::abs(quick.a.A) + std::abs(quick.b.A)) - D - margin;
  // & rather than &&, and |x| <= max for isfinite: without branches the batch vectorises.
  const double end = quick.value(t_to);
  const bool apart = (c.dist2 > 0.25 * D * D) & (quick.g0 > 0.0) & (end > 0.0) &
                     (std::abs(quick.slope(t_to)) <= std::numeric_limits<double>::max());
  proven = kept_or_zero(apart, quick.g0 < end ? quick.g0 : end);
  return apart;
}

// The same separation along a direction that turns, n(s) = n rotated by omega s: still a
// lower bound of the gap at every s, and with omega chosen so that n(s) stays square to each
// axis whose closest point is interior (omega . (e x n) = w . (e x n)), its slope at s = 0 is
// the gap's true rate. (With n fixed, a rod's turning brings its far end towards the other
// body's plane at h |w|, however far aside that end is: the bound's slope is then several
// times the true rate and the advancement only linear.) Remainders, with d'' bounds:
//   n(s).e(s) = n.E(s), E(s) = R(omega s)^T R(w s) e, E'' = R(omega s)^T ((w - omega) x (w x e(s))
//   - omega x ((w - omega) x e(s))): n(s).e(s) = A + s n.((w - omega) x e) + R with
//   |R| <= |w - omega| (|w| + |omega|) s^2 / 2,
//   n(s).(dx + s dv) = n.dx + s (n.dv + (omega x n).dx) + R_x,
//   |R_x| <= s^2 (|omega|^2 |dx| + 2 |omega| |dv|) / 2 + s^3 |omega|^2 |dv| / 6
// (dx = x_a - x_b, dv = v_a - v_b). Inline always: the search (contact_time.cpp) and the
// detection's screen in vector lanes (apart_turning) build it with the same bits.
[[gnu::always_inline]] inline GapBound turning_bound(const Vec3 &n, const Vec3 &omega,
                                                     const Vec3 &dx, const Vec3 &dv, const Vec3 &ea,
                                                     const Vec3 &wa, const Vec3 &eb, const Vec3 &wb,
                                                     double h, double g0) {
  const double om = norm(omega), om2 = om * om, ndv = norm(dv);
  GapBound out;
  out.g0 = g0;
  out.h = h;
  out.closing = dot(n, dv) + dot(cross(omega, n), dx);
  out.q2 = 0.5 * (om2 * norm(dx) + 2.0 * om * ndv);
  out.q3 = om2 * ndv / 6.0;
  out.a.A = dot(n, ea);
  out.a.C = dot(n, cross(wa - omega, ea));
  out.a.K2 = 0.5 * norm(wa - omega) * (norm(wa) + om);
  out.b.A = dot(n, eb);
  out.b.C = dot(n, cross(wb - omega, eb));
  out.b.K2 = 0.5 * norm(wb - omega) * (norm(wb) + om);
  return out;
}

// x where p, else y: a select per component (branch free, for vector lanes).
[[gnu::always_inline]] inline Vec3 select3(bool p, const Vec3 &x, const Vec3 &y) {
  return Vec3{p ? x.x : y.x, p ? x.y : y.y, p ? x.z : y.z};
}

// separating_normal (contact_time.cpp) without branches: the closest points' direction made
// square to each axis whose closest point is interior (both: the normal of the axes' plane).
[[gnu::always_inline]] inline Vec3 separating_normal_lanes(const SegmentClosest &c, const Vec3 &ea,
                                                           const Vec3 &eb, double h) {
  const Vec3 n0 = (1.0 / std::sqrt(c.dist2)) * c.gap;
  const bool inner_a = std::abs(c.s) < h, inner_b = std::abs(c.t) < h;
  const Vec3 f = std::copysign(1.0, dot(ea, eb)) * eb;
  const Vec3 x = cross(ea - f, ea);
  const double x2 = norm2(x);
  const Vec3 nx = (1.0 / std::sqrt(x2)) * x;
  const Vec3 n_both = select3(dot(nx, n0) < 0.0, -nx, nx);
  const Vec3 ma0 = n0 - dot(n0, ea) * ea, mb0 = n0 - dot(n0, eb) * eb;
  const double ma2 = norm2(ma0), mb2 = norm2(mb0);
  const Vec3 n_a = select3(ma2 > 1e-200, (1.0 / std::sqrt(ma2)) * ma0, n0);
  const Vec3 n_b = select3(mb2 > 1e-200, (1.0 / std::sqrt(mb2)) * mb0, n0);
  return select3(inner_a & inner_b & (x2 > 1e-28), n_both,
                 select3(inner_a, n_a, select3(inner_b, n_b, n0)));
}

// The refined screen (apart_in_flight's second test): the same separation along a normal that
// turns with the bodies (turning_bound above; contact_time.cpp explains turning_rates), from the
// separating normal (separating_normal: the closest points' direction made square to each axis
// whose closest point is interior), for each of its up to three rates: both axes held square,
// or the faster-turning one alone where the axes are within ~6 degrees, or the one interior
// axis. Then the plain Lipschitz bound. The same arithmetic as those functions, without
// branches (selects), so that the detection runs it over a batch in vector lanes, and the
// scalar apart_in_flight with the same bits. False when not proven (also for closest points
// nearer than D / 2, and for non-finite input). `proven` as apart_along_gap's: the largest of
// the least values of the bounds that proved it (the Lipschitz bound's at t_to), else 0.
[[gnu::always_inline]] inline bool apart_turning(const Vec3 &ea, const Vec3 &va, const Vec3 &wa,
                                                 const Vec3 &eb, const Vec3 &vb, const Vec3 &wb,
                                                 const Vec3 &r, const SegmentClosest &c, double h,
                                                 double D, double t_to, double margin,
                                                 double &proven) {
  constexpr double big = std::numeric_limits<double>::max();
  const auto finite = [](double x) { return std::abs(x) <= big; };
  const Vec3 n = separating_normal_lanes(c, ea, eb, h);
  const bool inner_a = std::abs(c.s) < h, inner_b = std::abs(c.t) < h;
  // pair_state_from's checks and the fixed bound's g0 (with the margin taken off)
  const double gap = std::sqrt(c.dist2) - D;
  const Vec3 ua = va + cross(wa, c.s * ea), ub = vb + cross(wb, c.t * eb);
  const double rate = dot(n, ua - ub);
  const double closing = dot(n, va - vb);
  const double g0 = (-dot(n, r) - h * (std::abs(dot(n, ea)) + std::abs(dot(n, eb))) - D) - margin;
  const bool usable = (c.dist2 > 0.25 * D * D) & finite(gap) & finite(rate) & finite(g0) &
                      finite(closing) & (gap > margin);
  // turning_rates
  const Vec3 ma = cross(ea, n), mb = cross(eb, n);
  const double ga = norm2(ma), gb = norm2(mb), gab = dot(ma, mb);
  const double ra = dot(wa, ma), rb = dot(wb, mb);
  const bool both = inner_a & inner_b;
  const double det = ga * gb - gab * gab;
  const bool with_both = both & (det > 1e-12 * ga * gb);
  const bool only_both = both & (det > 1e-2 * ga * gb);
  const bool a_faster = std::abs(ra) >= std::abs(rb);
  const bool keep_a = inner_a & ((!both) | ((!only_both) & a_faster));
  const bool keep_b = inner_b & ((!both) | ((!only_both) & (!a_faster)));
  const Vec3 omega_both = ((gb * ra - gab * rb) / det) * ma + ((ga * rb - gab * ra) / det) * mb;
  const Vec3 omega_a = (ra / ga) * ma, omega_b = (rb / gb) * mb;
  // turning_bound for a rate, and whether it clears [0, t_to]
  const Vec3 dx = -r, dv = va - vb;
  // Each rate's bound: its least value on [0, t_to] where it clears, else 0.
  const auto least = [&](bool tried, const Vec3 &omega) __attribute__((always_inline)) {
    const GapBound b = turning_bound(n, omega, dx, dv, ea, wa, eb, wb, h, g0);
    const double end = b.value(t_to);
    const bool clears = tried & (b.g0 > 0.0) & finite(b.slope(t_to)) & (end > 0.0);
    return kept_or_zero(clears, b.g0 < end ? b.g0 : end);
  };
  const double by_both = least(with_both, omega_both);
  const double by_a = least(keep_a & (ga > 0.5), omega_a);
  const double by_b = least(keep_b & (gb > 0.5), omega_b);
  const bool turned = (by_both > 0.0) | (by_a > 0.0) | (by_b > 0.0);
  const double lipschitz = norm(dv) + h * (norm(wa) + norm(wb));  // |d gap / dt|
  const bool plain = !((gap - margin) / lipschitz < t_to);
  const double by_plain = kept_or_zero(plain, (gap - margin) - lipschitz * t_to);
  const double best = std::max(std::max(by_both, by_a), std::max(by_b, by_plain));
  const bool apart = usable & (turned | plain);
  proven = kept_or_zero(apart, best);
  return apart;
}

}  // namespace hardrod
