// Contact detection at the midpoint of the step (the midpoint method): the narrow phase over
// the pairs the scan finds due (kernels/pair_scan.hpp). A listed pair is measured
// (segment_closest) only when the motion bounds of its bodies have used up its recorded slack;
// then its slack is renewed. Every pair with axis distance < D becomes a Contact, in canonical
// order. Reads positions, axes, motion bounds; writes the list's slacks and watches and the
// contacts. Threads split the bodies (or the pairs); per-thread contact blocks are merged and
// sorted, so the result does not depend on the thread count.
// Also the narrow phase both methods share: a pair's contact geometry (make_contact,
// contact_geometry).
#pragma once

#include <memory>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/contact.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/pair_scan.hpp"
#include "kernels/particles.hpp"
#include "kernels/segment_geometry.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

// The midpoint method's contacts: the pairs that overlap.
DetectionStats detect_contacts(const Particles &p, const Box &box, const Shape &shape,
                               NeighborList &list, std::vector<Contact> &contacts);

// The watched detection's parts, for a team of threads that has other work in the same
// parallel region (advance_to_midpoint, free_flight.hpp): every thread of the team calls
// detect_watched_in_team (it has barriers), then one thread calls finish_watched_detection,
// which merges the contacts (or, when too many bodies were flagged, switches the list to the
// full pass and runs it).
class WatchedDetection {
 public:
  WatchedDetection(int threads, const Box &box, const Shape &shape);
  ~WatchedDetection();
  WatchedTeam team;
  struct Measure;
  std::unique_ptr<Measure> measure;
};
void detect_watched_in_team(const Particles &p, NeighborList &list, WatchedDetection &shared);
DetectionStats finish_watched_detection(const Particles &p, NeighborList &list,
                                        WatchedDetection &shared, std::vector<Contact> &contacts);

// The reference: the same filter as a pass over every listed pair (how the watches must
// behave, and what they save). It renews slacks but not allowances: a list it has used is
// not fit for detect_contacts until arm_watches.
DetectionStats detect_contacts_all_pairs(const Particles &p, const Box &box, const Shape &shape,
                                         NeighborList &list, std::vector<Contact> &contacts);

// A contact's normal, lever arms and inverse effective mass (Contact, contact.hpp) from the
// closest points `sc` of axes e_i, e_j at separation r_ij = x_j - x_i: shared by the midpoint
// method's contacts (make_contact) and the exact method's collisions
// (kernels/exact/exact_events.hpp), so both give the same impulse for the same touching
// configuration.
inline void contact_geometry(const SegmentClosest &sc, const Vec3 &r_ij, const Vec3 &e_i,
                             const Vec3 &e_j, const Shape &shape, Contact &c) {
  c.normal = contact_normal(sc, r_ij, e_i, e_j);
  c.arm_i = sc.s * cross(e_i, c.normal);
  c.arm_j = sc.t * cross(e_j, c.normal);
  const double inv_m = 1.0 / shape.mass;
  const double inv_i = shape.inverse_inertia();
  c.inverse_mass = 2.0 * inv_m + inv_i * (norm2(c.arm_i) + norm2(c.arm_j));
}

// Fill the geometric fields of a contact between bodies a and b (any order; the result is
// canonical). Returns false when the pair does not overlap (distance >= D), or, with `reach`,
// is not closer than D + reach. `inverse` is box.inverse_length().
bool make_contact(const Particles &p, const Box &box, const Vec3 &inverse, const Shape &shape,
                  std::uint32_t a, std::uint32_t b, Contact &c, double &distance,
                  double reach = 0.0);

}  // namespace hardrod
