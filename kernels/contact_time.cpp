// First contact time of two free-flying capsules (contact_time.hpp). Stub bodies for now.
#include "kernels/contact_time.hpp"

namespace hardrod {

Vec3 Flight::position(double t) const { return x + (t - t0) * v; }

Vec3 Flight::axis(double /*t*/) const { return e; }

ContactTime first_contact(const Flight & /*a*/, const Flight & /*b*/, double /*h*/, double /*D*/,
                          double /*t_from*/, double t_to,
                          const ContactTimeSettings & /*settings*/) {
  ContactTime out;
  out.t = t_to;
  return out;
}

}  // namespace hardrod
