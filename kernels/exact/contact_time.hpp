// The exact first contact time of two capsules in free flight within a time step
// (run.method = "exact"): the kernel the event processing asks "when do these two first touch?".
// Physics: each body translates uniformly and its axis turns about a fixed angular velocity
// (a free linear rotor, docs/physics.md section 3). Spheres have a closed form; rods use
// conservative advancement on a rigorous lower bound of the surface gap, so no contact is ever
// skipped. Pure functions, no state, no threads, no I/O.
#pragma once

#include <algorithm>
#include <cmath>

#include "kernels/segment_geometry.hpp"
#include "kernels/vec3.hpp"

namespace hardrod {

// One body's free flight inside a time step, from time t0 on: centre x + v (t - t0); axis e
// turned about w by the angle |w| (t - t0) (exact Rodrigues rotation of a free linear rotor:
// e cos a + (w^ x e) sin a + w^ (w^ . e)(1 - cos a), with the small-angle case by series,
// never dividing by |w| = 0). Spheres: w = 0.
struct Flight {
  Vec3 x, e, v, w;
  double t0 = 0.0;
  Vec3 position(double t) const { return x + (t - t0) * v; }
  Vec3 axis(double t) const;
};

struct ContactTimeSettings {
  double tolerance = 1e-10;  // a contact: surface gap <= tolerance (in D) while the pair approaches
  int max_iterations = 200;  // gap evaluations per search before it gives up (converged = false)
};

struct ContactTime {
  bool found = false;     // a contact in [t_from, t_to]
  bool converged = true;  // false: max_iterations used up; then t is a rigorous lower bound of
                          // the first contact
  double t = 0.0;         // the contact time (found), or how far the search proved the pair apart
  int iterations = 0;     // gap evaluations (segment distances) used
};

// Spheres (h = 0): r(s) = r0 + u s with u = v_b - v_a. They meet where |r(s)| = D + tolerance/2:
// half a tolerance early, so the returned gap is in (0, tolerance] whatever the round-off of
// the root (a few eps |r0|). |r(s)|^2 is convex in s: once receding, never meeting again.
inline ContactTime sphere_contact(const Flight &a, const Flight &b, double D, double t_from,
                                  double t_to, const ContactTimeSettings &settings) {
  ContactTime out;
  out.iterations = 1;
  const Vec3 r0 = b.position(t_from) - a.position(t_from);
  const Vec3 u = b.v - a.v;
  const double dist = norm(r0);
  const double gap = dist - D;
  const double approach = dot(r0, u);  // < 0: closing
  if (!std::isfinite(gap) || !std::isfinite(approach) || !std::isfinite(norm2(u))) {
    out.converged = false;
    out.t = t_from;
    return out;
  }
  const double tol = settings.tolerance;
  if (gap <= -tol || (gap <= tol && approach < 0.0)) {  // overlapping, or touching and closing
    out.found = true;
    out.t = t_from;
    return out;
  }
  out.t = t_to;
  if (approach >= 0.0 || gap <= tol) return out;  // receding, or touching and not closing
  const double target = D + 0.5 * tol;
  const double c0 = (dist - target) * (dist + target);  // > 0: gap > tol
  const double disc = approach * approach - norm2(u) * c0;
  if (disc < 0.0) return out;                           // closest approach farther than the target
  const double s = c0 / (-approach + std::sqrt(disc));  // the smaller root, without cancellation
  if (t_from + s <= t_to) {
    out.found = true;
    out.t = t_from + s;
  }
  return out;
}

// Rods (h > 0): conservative advancement (contact_time.cpp).
ContactTime rod_contact(const Flight &a, const Flight &b, double h, double D, double t_from,
                        double t_to, const ContactTimeSettings &settings);

// The first time t in [t_from, t_to] at which capsules a and b (axis half length h, diameter D;
// h = 0: spheres) touch: surface gap g(t) = |closest points of the axes| - D <= tolerance while
// approaching (dg/dt < 0). b's centre is already the periodic image nearest a's (the caller
// applies the minimum image). Never later than the true first contact (no contact is skipped):
// the search is rigorous, not sampled. Spheres: closed form (stable quadratic root).
// If the pair touches and separates at t_from (a collision between them was just processed),
// that touch is not reported: the search starts once they part, and finds a later contact if
// there is one.
//
// The rules, in order, at each time t the search visits (t_from first):
// - gap <= -tolerance (an overlap; only possible at t_from): found at t. Whether or not the
//   pair approaches: an overlap is never hidden from the caller.
// - gap <= tolerance and dg/dt < 0 (the rate of the closest material points along the normal):
//   found at t.
// - gap <= tolerance and not approaching (touching and separating, or grazing): the search
//   steps on with the gap proven above -tolerance (not above 0) until the pair parts, so the
//   worst overlap it can pass without reporting is the tolerance itself; a contact found while
//   still touching can have a gap down to -tolerance. (Steps grow geometrically as the gap
//   opens: 1.05 evaluations on average to clear the rest of a 1e-2 step after an elastic
//   collision.)
// - else a step that the bound proves contact-free (gap > 0 on it); and if the pair approached
//   at t from apart (gap above the tolerance) and an upper bound of the gap at the step's end
//   (the distance of the material points closest at t) is within half the tolerance, found at
//   the step's end without evaluating there: its gap is in [0, tolerance / 2]. This is the time
//   the evaluation there would report (unless the pair stopped approaching within the step: a
//   graze the caller sees as one), one evaluation sooner.
// Spheres use the closed form under the same rules: touching and not approaching is never a
// contact (their distance is convex in time), and the contact is where the gap is tolerance/2,
// so that its round-off keeps it in (0, tolerance]; iterations = 1.
// Rods: a found contact has gap in [-1e-12, tolerance] away from the touching start (round-off
// of the segment distance at L/D = 1000 included). Evaluations (tests/kernels/
// test_contact_time.cpp, random nematic collisions, gap 0 .. 0.05 D at the start, dt 1e-3 ..
// 3e-2): L/D 5 mean 3.5, max 8 per search that finds a contact (4.4 and 9 without the upper
// bound's shortcut), 1.4 over all searches; L/D 1000 mean 2.6, max 5 (3.5, 6). The everyday
// nematic from its equilibrated state (exact, dt 2e-3): 1.51 per search (1.79 without).
// converged = false only when max_iterations evaluations reached neither a contact nor t_to
// (never in those tests), or a safe step fell below the resolution of t; non-finite input:
// converged = false at once, t = t_from. Times are best measured from the step's start (t0,
// t_from near 0): a step is resolved to an ulp of t, and near the tolerance steps are ~1e-11 tau.
inline ContactTime first_contact(const Flight &a, const Flight &b, double h, double D,
                                 double t_from, double t_to, const ContactTimeSettings &settings) {
  if (!(t_to >= t_from) || !std::isfinite(t_from) || !std::isfinite(t_to)) {
    ContactTime out;  // an empty or non-finite interval: nothing searched
    out.t = t_from;
    out.converged = std::isfinite(t_from) && std::isfinite(t_to);
    return out;
  }
  if (h <= 0.0) return sphere_contact(a, b, D, t_from, t_to, settings);
  return rod_contact(a, b, h, D, t_from, t_to, settings);
}

// The exact method's screen of its candidates (step_candidates.hpp, StepAhead): true when
// the free flights of a and b alone (both from t0 = 0) keep their surfaces more than `margin`
// apart over [0, t_to], proven by the bound of the search's first step, from the closest
// points `c` of axes a.e, b.e at separation r = x_b - x_a (b's nearest image) that the caller
// has measured already. Then first_contact(a, b, h, D, 0, t_to) finds nothing however its own
// r is rounded, when margin is far above that rounding and above the tolerance
// (kApartMargin). False when not proven, and for non-finite input.
inline constexpr double kApartMargin = 1e-9;
bool apart_in_flight(const Flight &a, const Flight &b, const Vec3 &r, const SegmentClosest &c,
                     double h, double D, double t_to, double margin);
// Its test for spheres (h = 0), inline so that the detection runs it over a batch in vector
// lanes (the same bits): the least distance of r + u s on [0, t_to], u = b.v - a.v, above
// D + margin. NaN: not apart. `proven`, as the rods' screens give it (gap_bound.hpp): where
// apart, that least distance less D + margin, else 0.
inline bool spheres_apart(const Vec3 &r, const Vec3 &u, double D, double t_to, double margin,
                          double &proven) {
  const double uu = norm2(u);
  const double s = uu > 0.0 ? std::clamp(-dot(r, u) / uu, 0.0, t_to) : 0.0;
  const double least = norm(r + s * u) - D;
  const bool apart = least > margin;
  proven = apart ? least - margin : 0.0;
  return apart;
}
// For rods, apart_in_flight = apart_along_gap || apart_turning (gap_bound.hpp), the two screens
// the detection runs over a batch of candidates in vector lanes, with the same bits.

}  // namespace hardrod
