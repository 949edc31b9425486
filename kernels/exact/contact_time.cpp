// First contact time of two free-flying capsules (contact_time.hpp).
// Spheres: the stable root of |r + u s| = D. Rods: conservative advancement. At a time t proven
// contact-free, the closest points of the axes give the gap g and the unit normal n (from b to
// a); the separation of the two capsules along this fixed n is a lower bound of their gap at
// every later time, and its Taylor model L(s) (below) is concave in s >= 0, so its
// first root is a step the pair cannot touch within. Each step costs one segment distance.
// Along a fixed n the slope of L is too steep where a closest point is interior (see
// turning_bound); there the same separation along a turning n(s) gives the true slope.
//
// The bound, for s >= 0 (a = |w| s the angle turned; A = n.e, B = n.(w^ x e), P = (n.w^)(w^.e)):
//   n.e(s) = A cos a + B sin a + P (1 - cos a) = A + B a + (P - A)(1 - cos a) - B (a - sin a),
//   |n.e(s)| <= |A + B a| + |P - A| a^2 / 2 + |B| a^3 / 6,
//   gap(t + s) >= g + s n.(v_a - v_b) - h sum_bodies (|A + C s| - |A| + K2 s^2 + K3 s^3) = L(s)
// with C = |w| B = n.(w x e), K2 = |(n.w)(w.e) - |w|^2 A| / 2, K3 = |C| |w|^2 / 6 (no division
// by |w|). Every term is concave in s >= 0 (-|linear|, -s^2, -s^3), so L is concave there,
// {L > 0} is one interval [0, s*), a chord between a point with L > 0 and one with L <= 0
// meets zero before s*, and a tangent (supergradient) at a point beyond s* meets zero after it.
#include "kernels/exact/contact_time.hpp"

#include <algorithm>
#include <cmath>

#include "kernels/exact/gap_bound.hpp"

namespace hardrod {
namespace {

// sin(a)/a and (1 - cos a)/a^2 as series in a^2, for a^2 < kSeriesAngle2: the next terms are
// below a^10 / 4e7 < 3e-18 there, so the result is exact to round-off.
constexpr double kSeriesAngle2 = 1e-2;

double sinc_series(double a2) {
  return 1.0 + a2 * (-1.0 / 6 + a2 * (1.0 / 120 + a2 * (-1.0 / 5040 + a2 * (1.0 / 362880))));
}

double versine_series(double a2) {
  return 0.5 + a2 * (-1.0 / 24 + a2 * (1.0 / 720 + a2 * (-1.0 / 40320 + a2 * (1.0 / 3628800))));
}

// Least-norm rates omega with omega . m_k = w_k . m_k (m_k = e_k x n) for the interior bodies:
// both, a 2x2 Gram system; where the axes are nearly parallel that omega grows as 1 / angle,
// and its remainders limit the step far from contact (not near it, where the step is short),
// so then also the omega for the faster-turning axis alone. Returns how many (0 to 2).
int turning_rates(const Vec3 &n, const Vec3 &ea, const Vec3 &wa, bool inner_a, const Vec3 &eb,
                  const Vec3 &wb, bool inner_b, Vec3 omega[2]) {
  const Vec3 ma = cross(ea, n), mb = cross(eb, n);
  const double ga = norm2(ma), gb = norm2(mb), gab = dot(ma, mb);
  const double ra = dot(wa, ma), rb = dot(wb, mb);
  int count = 0;
  if (inner_a && inner_b) {
    const double det = ga * gb - gab * gab;
    if (det > 1e-12 * ga * gb) {
      const double alpha = (gb * ra - gab * rb) / det, beta = (ga * rb - gab * ra) / det;
      omega[count++] = alpha * ma + beta * mb;
    }
    if (det > 1e-2 * ga * gb) return count;  // axes more than ~6 degrees apart
    (std::abs(ra) >= std::abs(rb) ? inner_b : inner_a) = false;
  }
  if (inner_a && ga > 0.5) omega[count++] = (ra / ga) * ma;
  if (inner_b && gb > 0.5) omega[count++] = (rb / gb) * mb;
  return count;
}

// A step s in [0, s_max] with bound > 0 on [0, s) (bound.value(0) > 0): s_max if the bound
// stays positive up to it (`clear`), else a point at or below the first root. Chords from the
// left (below the root of a concave function) and tangents from the right (above it), a few
// rounds only: the step need not be the root, only safe and close.
struct SafeStep {
  double s = 0.0;
  bool clear = false;
};

SafeStep safe_step(const GapBound &bound, double s_max) {
  double lo = 0.0, f_lo = bound.value(0.0);
  double hi = s_max, f_hi = bound.value(s_max);
  if (f_hi > 0.0) return {s_max, true};  // concave, positive at both ends: positive between
  constexpr int kRounds = 2;             // 2 to 6 rounds: the same evaluations; 2 the fastest
  constexpr double kClose = 1e-3;        // stop once the root is bracketed to 0.1 %
  for (int round = 0; round < kRounds && hi - lo > kClose * hi; ++round) {
    const double q = bound.slope(hi);
    if (q < 0.0) {
      const double s = hi - f_hi / q;  // tangent from the right: not below the root
      if (s > lo && s < hi) {
        const double f = bound.value(s);
        (f > 0.0 ? lo : hi) = s;
        (f > 0.0 ? f_lo : f_hi) = f;
      }
    }
    // The chord, kept off the ends: where round-off would put it on hi (a root within an ulp
    // or two of hi) the step lands just below hi instead, and every round moves an end.
    const double frac = f_lo > f_hi ? f_lo / (f_lo - f_hi) : 0.5;
    const double s = lo + std::clamp(frac, kClose, 1.0 - kClose) * (hi - lo);
    if (!(s > lo && s < hi)) break;
    const double f = bound.value(s);
    (f > 0.0 ? lo : hi) = s;
    (f > 0.0 ? f_lo : f_hi) = f;
  }
  return {lo, false};
}

Vec3 unit_or(const Vec3 &v, const Vec3 &fallback) {
  const double v2 = norm2(v);
  return v2 > 1e-200 ? (1.0 / std::sqrt(v2)) * v : fallback;
}

// The direction of the closest points, made orthogonal to each axis whose closest point is
// interior (as it is exactly there). The bound loses h |n . e| at once, and for long rods the
// closest points' round-off (eps |s| |e|) tilts gap/|gap| enough for that to reach 1e-10 D.
// Both interior: the normal of the plane of both axes, by contact_normal's e_a x (e_a - f).
Vec3 separating_normal(const SegmentClosest &c, const Vec3 &r, const Vec3 &ea, const Vec3 &eb,
                       double h) {
  const Vec3 n0 = contact_normal(c, r, ea, eb);
  const bool inner_a = std::abs(c.s) < h, inner_b = std::abs(c.t) < h;
  if (inner_a && inner_b) {
    const Vec3 f = std::copysign(1.0, dot(ea, eb)) * eb;
    const Vec3 x = cross(ea - f, ea);
    if (norm2(x) > 1e-28) {
      const Vec3 n = unit_or(x, n0);
      return dot(n, n0) < 0.0 ? -n : n;
    }
  }
  if (inner_a) return unit_or(n0 - dot(n0, ea) * ea, n0);
  if (inner_b) return unit_or(n0 - dot(n0, eb) * eb, n0);
  return n0;
}

// The pair at time t: gap, its rate, and the bound of its later values along the fixed
// normal; what the turning normal's bound needs, for when that one does not clear the step.
struct PairState {
  double gap = 0.0;   // |closest points| - D
  double rate = 0.0;  // d gap / dt (< 0: approaching)
  GapBound fixed;     // margin 0
  Vec3 n, r, ea, eb;
  bool inner_a = false, inner_b = false;
  // The closest material points: their separation (a's minus b's), its rate, and how far
  // their turning can bend it (upper_gap).
  Vec3 separation, separation_rate;
  double bend = 0.0;
};

// An upper bound of the gap at t + s: the distance of the two material points closest at t
// bounds the segments' distance from above. A point at arm c on an axis turning at w moves as
// x + v s + c e(s), and |e(s) - e - s w x e| <= |w|^2 s^2 / 2, so the points' separation is
// separation + s separation_rate within bend s^2, bend = (|c_a| |w_a|^2 + |c_b| |w_b|^2) / 2.
double upper_gap(const PairState &st, double D, double s) {
  return norm(st.separation + s * st.separation_rate) + st.bend * s * s - D;
}

// From the closest points c of axes ea, eb at separation r = x_b - x_a, the bodies' rates
// from their flights.
PairState pair_state_from(const SegmentClosest &c, const Vec3 &r, const Vec3 &ea, const Vec3 &eb,
                          const Flight &a, const Flight &b, double h, double D) {
  PairState st;
  st.ea = ea;
  st.eb = eb;
  st.r = r;
  st.n = separating_normal(c, st.r, st.ea, st.eb, h);
  st.inner_a = std::abs(c.s) < h;
  st.inner_b = std::abs(c.t) < h;
  st.gap = std::sqrt(c.dist2) - D;
  // Velocities of the closest material points; the parameters' own motion does not change the
  // distance to first order (they minimise it).
  const Vec3 ua = a.v + cross(a.w, c.s * st.ea), ub = b.v + cross(b.w, c.t * st.eb);
  st.rate = dot(st.n, ua - ub);
  st.separation = c.gap;
  st.separation_rate = ua - ub;
  st.bend = 0.5 * (std::abs(c.s) * norm2(a.w) + std::abs(c.t) * norm2(b.w));
  GapBound &fixed = st.fixed;
  fixed.a = axis_bound(st.n, st.ea, a.w);
  fixed.b = axis_bound(st.n, st.eb, b.w);
  fixed.h = h;
  fixed.closing = dot(st.n, a.v - b.v);
  // The separation along n itself, not the segment distance: a lower bound of the true gap
  // whatever the round-off of the closest points (equal to it in exact arithmetic).
  fixed.g0 = -dot(st.n, st.r) - h * (std::abs(fixed.a.A) + std::abs(fixed.b.A)) - D;
  return st;
}

PairState pair_state(const Flight &a, const Flight &b, double h, double D, double t) {
  const Vec3 ea = a.axis(t), eb = b.axis(t);
  const Vec3 r = b.position(t) - a.position(t);
  return pair_state_from(segment_closest_inline(r, ea, h, eb, h), r, ea, eb, a, b, h, D);
}

// The checks rod_contact makes before it steps: a state it can step from.
bool finite_state(const PairState &st) {
  return std::isfinite(st.gap) && std::isfinite(st.rate) && std::isfinite(st.fixed.g0) &&
         std::isfinite(st.fixed.closing);
}

// A step the bounds prove contact-free from the pair state, gap + margin > 0 on it: the fixed
// normal's test at s_max first (cheap; it clears most steps of pairs that do not meet), then
// the turning normal's step where a closest point is interior, else the fixed normal's. (The
// larger of both steps saves too few evaluations to pay for the second test.)
SafeStep contact_free_step(const PairState &st, const Flight &a, const Flight &b, double h,
                           double margin, double s_max) {
  GapBound fixed = st.fixed;
  fixed.g0 += margin;
  const bool fixed_ok = fixed.g0 > 0.0 && std::isfinite(fixed.slope(s_max));
  if (fixed_ok && fixed.value(s_max) > 0.0) return {s_max, true};
  SafeStep step;
  Vec3 omega[2];
  const int rates = turning_rates(st.n, st.ea, a.w, st.inner_a, st.eb, b.w, st.inner_b, omega);
  for (int k = 0; k < rates && !step.clear; ++k) {
    const GapBound turning =
        turning_bound(st.n, omega[k], -st.r, a.v - b.v, st.ea, a.w, st.eb, b.w, h, fixed.g0);
    if (!(turning.g0 > 0.0) || !std::isfinite(turning.slope(s_max))) continue;
    const SafeStep candidate = safe_step(turning, s_max);
    if (candidate.clear || candidate.s > step.s) step = candidate;
  }
  if (!step.clear && fixed_ok && step.s <= 0.0) {
    const SafeStep other = safe_step(fixed, s_max);
    if (other.clear || other.s > step.s) step = other;
  }
  if (!step.clear && step.s <= 0.0) {
    // Round-off left no bound positive (the gap along n below the margin where the segment
    // distance is barely above it): the plain bound gap(t + s) >= gap(t) - lipschitz s.
    const double lipschitz = norm(a.v - b.v) + h * (norm(a.w) + norm(b.w));  // |d gap / dt|
    step.s = (st.gap + margin) / lipschitz;
    step.clear = !(step.s < s_max);
  }
  return step;
}

}  // namespace

ContactTime rod_contact(const Flight &a, const Flight &b, double h, double D, double t_from,
                        double t_to, const ContactTimeSettings &settings) {
  const double tol = settings.tolerance;
  ContactTime out;
  double t = t_from;
  for (;;) {
    if (out.iterations >= settings.max_iterations) {
      out.converged = false;
      out.t = t;
      return out;
    }
    PairState st = pair_state(a, b, h, D, t);
    ++out.iterations;
    if (!finite_state(st)) {
      out.converged = false;
      out.t = t;
      return out;
    }
    // A contact: touching and closing, or overlapping by more than the tolerance (possible
    // only at t_from: the steps below never let the gap fall below -tolerance).
    if (st.gap <= -tol || (st.gap <= tol && st.rate < 0.0)) {
      out.found = true;
      out.t = t;
      return out;
    }
    // Touching but not closing (a collision just processed, or a graze): step on while the
    // gap stays above -tolerance, until the pair parts or closes again. Else above zero.
    const double margin = st.gap <= tol ? tol : 0.0;
    if (t >= t_to) {
      out.t = t_to;
      return out;
    }
    const SafeStep step = contact_free_step(st, a, b, h, margin, t_to - t);
    if (step.clear) {
      out.t = t_to;
      return out;
    }
    // t + s rounded down, so that rounding never carries the search past the proven step.
    double next = t + step.s;
    if (next - t > step.s) next = std::nextafter(next, t);
    if (!(next > t)) {  // the step is below the resolution of t: no progress possible
      out.converged = false;
      out.t = t;
      return out;
    }
    // Approaching from apart, and the points closest now are within half the tolerance of
    // touching at `next` (the gap there is in [0, tolerance / 2], the half for round-off): a
    // contact, without the evaluation that would confirm it. The searches that find a contact
    // take one evaluation fewer (3 or 4 in the nematic, the last from a gap of ~1e-9 D to
    // ~1e-19). If the pair parts there after all, the caller sees a graze.
    if (margin == 0.0 && st.rate < 0.0 && upper_gap(st, D, next - t) <= 0.5 * tol) {
      out.found = true;
      out.t = next;
      return out;
    }
    t = next;
  }
}

Vec3 Flight::axis(double t) const {
  const double tau = t - t0;
  // At the flight's start the axis itself (a search's first look, and a body just collided):
  // what the rotation below gives there, but for the sign of a zero component (e + 0).
  if (tau == 0.0) return e;
  const double w2 = norm2(w);
  const double a2 = w2 * tau * tau;
  double cos_a, sin_over_w, vers_over_w2;  // cos a, sin(a)/|w|, (1 - cos a)/|w|^2
  if (a2 < kSeriesAngle2) {
    const double vers = versine_series(a2);
    cos_a = 1.0 - a2 * vers;
    sin_over_w = tau * sinc_series(a2);
    vers_over_w2 = tau * tau * vers;
  } else {
    const double wn = std::sqrt(w2), ang = wn * tau;
    const double half_sin = std::sin(0.5 * ang);
    cos_a = std::cos(ang);
    sin_over_w = std::sin(ang) / wn;
    vers_over_w2 = 2.0 * half_sin * half_sin / w2;  // 1 - cos a without cancellation
  }
  return cos_a * e + sin_over_w * cross(w, e) + (vers_over_w2 * dot(w, e)) * w;
}

bool apart_in_flight(const Flight &a, const Flight &b, const Vec3 &r, const SegmentClosest &c,
                     double h, double D, double t_to, double margin) {
  double proven = 0.0;  // (what the one queue keeps: Candidate::proven)
  if (h <= 0.0) return spheres_apart(r, b.v - a.v, D, t_to, margin, proven);
  return apart_along_gap(a.e, a.v, a.w, b.e, b.v, b.w, r, c, h, D, t_to, margin, proven) ||
         apart_turning(a.e, a.v, a.w, b.e, b.v, b.w, r, c, h, D, t_to, margin, proven);
}

}  // namespace hardrod
