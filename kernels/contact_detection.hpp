// Contact detection at the midpoint of the step: the narrow phase over the neighbour list.
// A listed pair is measured (segment_closest) only when the motion bounds of its bodies
// have used up its recorded slack; then its slack is renewed. Every pair with axis distance
// < D becomes a Contact, in canonical order. Reads positions, axes, motion bounds; writes
// the list's slacks and watches and the contacts. Only the pairs of bodies whose bound
// reached their watch are read (neighbor_list.hpp). Threads split the bodies; per-thread
// contact blocks are merged and sorted, so the result does not depend on the thread count.
#pragma once

#include <vector>

#include "kernels/box.hpp"
#include "kernels/contact.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/particles.hpp"
#include "kernels/segment_geometry.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

struct DetectionStats {
  long long narrow_phase_tests = 0;  // segment distances computed this step
  double max_depth = 0.0;            // deepest overlap this step (0 if none)
  bool watched = false;              // through the watches, not a pass over every pair
  bool near = false;                 // a pass over the list's near pairs only (NearPairs)
};

// The midpoint method's contacts: the pairs that overlap.
DetectionStats detect_contacts(const Particles &p, const Box &box, const Shape &shape,
                               NeighborList &list, std::vector<Contact> &contacts);

// The exact method's candidates (kernels/exact/exact_collisions.hpp), with `ahead`: the bodies are
// at the start of the step, their motion bounds already include the whole step's free flight, and
// grow[i] is body i's growth per half step (Particles::grow). A candidate is a pair that could
// touch within the step (gap below the two flights, 2 (grow[i] + grow[j])), its depth negative
// when apart, and slacks are renewed for the start positions. A candidate is marked `apart`
// when its two free flights alone keep it apart through the step of length dt
// (apart_in_flight, contact_time.hpp): its first search would find nothing.
// `canonical`: the candidates come in canonical order (id_i, id_j), as the ranks' protocol
// needs; without, in the threads' order. One rank's clusters (collide_exactly) do not need it:
// a cluster's events are taken by time and then ids, whatever order its candidates were
// predicted in, so the trajectory is the same bits (and the sort was 4 % of the hard-sphere
// step).
// `allowance` (D, the one queue's ExactSettings::overrun_allowance): the pairs whose gap is
// below the two flights plus twice it come too, those beyond the flights as spares
// (Candidate::spare), and a listed pair not found is farther apart than that.
struct StepAhead {
  const double *grow = nullptr;
  double dt = 0.0;
  bool canonical = true;
  double allowance = 0.0;
};
DetectionStats detect_contacts(const Particles &p, const Box &box, const Shape &shape,
                               NeighborList &list, std::vector<Candidate> &candidates,
                               const StepAhead &ahead);

// The watched detection's parts, for a team of threads that has other work in the same
// parallel region (advance_to_midpoint, free_flight.hpp): every thread of the team calls
// detect_watched_in_team (it has barriers), then one thread calls finish_watched_detection,
// which merges the contacts (or, when too many bodies were flagged, switches the list to the
// full pass and runs it). `Found` is Contact, or Candidate for the exact method's detection.
template <class Found>
struct WatchedTeam {
  explicit WatchedTeam(int threads);
  std::vector<std::vector<Found>> found;
  std::vector<std::vector<std::uint32_t>> due;  // each thread's pairs to measure
  std::vector<long> ends;
  std::vector<long long> tests;
  std::vector<double> depth;
  bool watching = true;
};
using WatchedDetection = WatchedTeam<Contact>;
void detect_watched_in_team(const Particles &p, const Box &box, const Shape &shape,
                            NeighborList &list, WatchedDetection &shared);
DetectionStats finish_watched_detection(const Particles &p, const Box &box, const Shape &shape,
                                        NeighborList &list, WatchedDetection &shared,
                                        std::vector<Contact> &contacts);

// The reference: the same filter as a pass over every listed pair (how the watches must
// behave, and what they save). It renews slacks but not allowances: a list it has used is
// not fit for detect_contacts until arm_watches.
DetectionStats detect_contacts_all_pairs(const Particles &p, const Box &box, const Shape &shape,
                                         NeighborList &list, std::vector<Contact> &contacts);
DetectionStats detect_contacts_all_pairs(const Particles &p, const Box &box, const Shape &shape,
                                         NeighborList &list, std::vector<Candidate> &candidates,
                                         const StepAhead &ahead);

// A contact's normal, lever arms and inverse effective mass (Contact, contact.hpp) from the
// closest points `sc` of axes e_i, e_j at separation r_ij = x_j - x_i: shared by the midpoint
// method's contacts (make_contact) and the exact method's collisions (exact_collisions.cpp),
// so both give the same impulse for the same touching configuration.
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
