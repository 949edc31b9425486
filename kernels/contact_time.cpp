// TEMPORARY integration stub (replaced by the contact-time branch): spheres closed form, rods
// plain conservative advancement with the |v_rel| + h(|w_a| + |w_b|) rate.
#include "kernels/contact_time.hpp"

#include <cmath>

namespace hardrod {

Vec3 Flight::position(double t) const { return x + (t - t0) * v; }

Vec3 Flight::axis(double t) const {
  const double w2 = norm2(w);
  if (w2 == 0.0) return e;
  const double om = std::sqrt(w2), a = om * (t - t0);
  const Vec3 u = (1.0 / om) * w;
  return std::cos(a) * e + std::sin(a) * cross(u, e) + ((1.0 - std::cos(a)) * dot(u, e)) * u;
}

ContactTime first_contact(const Flight &a, const Flight &b, double h, double D, double t_from,
                          double t_to, const ContactTimeSettings &settings) {
  ContactTime out;
  out.t = t_to;
  if (h == 0.0) {  // spheres: |r + u s|^2 = D^2
    out.iterations = 1;
    const Vec3 r = a.position(t_from) - b.position(t_from), u = a.v - b.v;
    const double ru = dot(r, u), uu = norm2(u), c = norm2(r) - D * D;
    if (ru >= 0.0 || uu == 0.0) return out;
    const double disc = ru * ru - uu * c;
    if (disc < 0.0) return out;
    const double s = c <= 0.0 ? 0.0 : c / (-ru + std::sqrt(disc));
    if (t_from + s <= t_to) out.found = true, out.t = t_from + s;
    return out;
  }
  double t = t_from;
  while (t <= t_to && out.iterations < settings.max_iterations) {
    ++out.iterations;
    const Vec3 r = b.position(t) - a.position(t);
    const Vec3 ea = a.axis(t), eb = b.axis(t);
    const SegmentClosest sc = segment_closest_inline(r, ea, h, eb, h);
    const double g = std::sqrt(sc.dist2) - D;
    const Vec3 n = (1.0 / std::sqrt(sc.dist2)) * sc.gap;
    const Vec3 pa = a.v + cross(a.w, sc.s * ea), pb = b.v + cross(b.w, sc.t * eb);
    const double rate = dot(n, pa - pb);
    if (g <= settings.tolerance) {
      if (rate < 0.0) {
        out.found = true;
        out.t = t;
        return out;
      }
      t += 1e-9;  // touching and parting
      continue;
    }
    const double bound = norm(a.v - b.v) + h * (norm(a.w) + norm(b.w));
    if (bound <= 0.0) return out;
    t += g / bound;
  }
  out.converged = !(t <= t_to);
  if (!out.converged) out.t = t;
  return out;
}

}  // namespace hardrod
