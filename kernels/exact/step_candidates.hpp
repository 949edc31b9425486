// The exact method's detection at the step's start (run.method = "exact"): the narrow phase over
// the pairs the scan finds due (kernels/pair_scan.hpp), for bodies that are still at the start
// of the step while their motion bounds already hold the whole step's free flight (grow_bounds,
// kernels/free_flight.hpp). A candidate is a listed pair that could touch within the step (gap
// below the two flights, 2 (grow[i] + grow[j])), its depth negative when apart, and slacks are
// renewed for the start positions. A candidate is screened (gap_bound.hpp, in vector lanes):
// marked `apart` when its two free flights alone keep it apart through the step (its first
// search would find nothing), with the proof's least gap. Reads positions, axes, velocities,
// motion bounds and Particles::grow; writes the list's slacks and watches and the candidates.
// Threads split the bodies (or the pairs), each with its own candidates.
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/pair_scan.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

// A candidate: a listed pair that could touch within the step, with what its clusters read
// (exact_collisions.hpp). 40 bytes where a Contact is 152: thousands a step are written, sorted
// and read.
struct Candidate {
  std::uint32_t i = 0, j = 0;  // local body indices, id[i] < id[j]
  std::int64_t id_i = 0, id_j = 0;
  double depth = 0.0;  // D - d at the step's start (negative: apart)
  // The two free flights alone keep the pair apart all step: its first search would find nothing.
  bool apart = false;
  // Beyond the two free flights' reach, within the overrun allowance only (StepAhead::allowance):
  // a partner for the one queue's predictions after a velocity changes, not a candidate of the
  // free flights (apart too; not counted, and the clusters leave it out).
  bool spare = false;
  // Where apart (or a spare): a lower bound of the pair's surface gap less kApartMargin over the
  // whole step along the two free flights (the screens' bound at its least, or a spare's
  // distance beyond the flights' reach), rounded down to a float (beside the flags, the record
  // stays 40 bytes); else 0. The one queue keeps the pair apart with it after a velocity
  // changes, while it covers how far the new flights can stray (exact_queue.cpp).
  float proven = 0.0f;
};
static_assert(sizeof(Candidate) == 40, "thousands a step are sorted and copied");

// How the step is looked ahead: grow[i] is body i's growth per half step (Particles::grow), dt
// the step.
// `canonical`: the candidates come in canonical order (id_i, id_j), as the ranks' protocol
// needs; without, in the threads' order. One rank's clusters (collide_exactly) do not need it:
// a cluster's events are taken by time and then ids, whatever order its candidates were
// predicted in, so the trajectory is the same bits.
// `allowance` (D, the one queue's ExactSettings::overrun_allowance): the pairs whose gap is
// below the two flights plus twice it come too, those beyond the flights as spares
// (Candidate::spare), and a listed pair not found is farther apart than that.
struct StepAhead {
  const double *grow = nullptr;
  double dt = 0.0;
  bool canonical = true;
  double allowance = 0.0;
};

DetectionStats detect_candidates(const Particles &p, const Box &box, const Shape &shape,
                                 NeighborList &list, std::vector<Candidate> &candidates,
                                 const StepAhead &ahead);

// The reference: the same filter as a pass over every listed pair (kernels/pair_scan.hpp,
// scan_every_pair).
DetectionStats detect_candidates_all_pairs(const Particles &p, const Box &box, const Shape &shape,
                                           NeighborList &list, std::vector<Candidate> &candidates,
                                           const StepAhead &ahead);

}  // namespace hardrod
