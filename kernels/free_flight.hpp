// Free flight for half a time step (docs/physics.md section 3): x += v dt/2, and the axis
// turned about w by the angle |w| dt/2 (Rodrigues' rotation, exact for a free linear rotor;
// the renormalisation is left to restore_rotor_constraints, rotor_constraints.hpp). Each body's
// motion bound grows by the largest distance any point of it can have moved,
// (|v| + L/2 |w|) dt/2, which the neighbour list's pair checks rely on (neighbor_list.hpp).
// Centres are never folded back into the box: every separation goes through the minimum
// image, and the cell list and the domain fold when they bin, so the trajectory does not
// depend on when anything is folded.
// Also the step's first phase fused with its second: the flight to the midpoint and, in the
// same parallel region, the watched detection there (advance_to_midpoint); the detection
// itself is contact_detection.hpp's.
// Reads/writes positions, axes, motion bounds; reads velocities and the motion constants.
// Element-wise, each thread on its team_block (particles.hpp), no reductions but the
// largest bound: bit-identical for any thread count. No contacts, no impulses, no I/O.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/contact.hpp"
#include "kernels/contact_detection.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

// The motion constants (Particles::grow, turn_*) of bodies [lo, hi), of bodies [0, count)
// (threaded), or of the listed bodies, from their velocities as they are now. Due after
// anything changes a velocity and before the next drift_block of that body; half_step and
// two_half_steps refresh every body themselves.
void refresh_motion(Particles &p, long lo, long hi, const Shape &shape, double half_dt);
void refresh_motion(Particles &p, std::size_t count, const Shape &shape, double half_dt);
void refresh_motion(Particles &p, const std::vector<std::uint32_t> &bodies, const Shape &shape,
                    double half_dt);

// One or two half steps (`halves`) for bodies [lo, hi) only, with no threads of its own:
// for a thread of a team that takes the block team_block(...) (particles.hpp), as
// advance_to_midpoint does. Returns the block's largest motion bound. Reads the bodies'
// motion constants: they must be current (refresh_motion).
double drift_block(Particles &p, long lo, long hi, const Shape &shape, double half_dt, int halves);

// One or two half steps (`halves`) for bodies [0, count), threads splitting them in team
// blocks above kParallelBodies, with the motion constants as they are (refresh_motion).
double free_flight(Particles &p, std::size_t count, const Shape &shape, double half_dt, int halves);

// Refresh every body's motion constants, then one half step. Returns the largest motion
// bound of the bodies after it.
double half_step(Particles &p, std::size_t count, const Shape &shape, double half_dt);

// Two half steps in one pass over the bodies, bit for bit the same as two calls of
// half_step: the second half of a step fused with the first half of the next, when nothing
// happens between them (no contacts are resolved between the two halves of one pass).
double two_half_steps(Particles &p, std::size_t count, const Shape &shape, double half_dt);

// The exact method's step (kernels/exact/exact_collisions.hpp) grows the motion bounds before it
// moves the bodies, so that the detection at the step's start sees the whole step's flight:
// grow_bounds adds two half steps' growth to bodies [0, count) (the same additions as
// two_half_steps; returns the largest bound, or NaN or infinity if any bound is not finite),
// and fly_step then moves them by the two half
// steps (positions and axes, the same bits as two_half_steps) leaving the bounds alone.
// Both read the motion constants as they are (refresh_motion).
double grow_bounds(Particles &p, std::size_t count);
// The same, and in the same pass what a list's extension asks (kernels/exact/list_extension.hpp):
// the largest bound less the body's extra reach (extra: [0, count); null where none has any:
// then the largest bound, and one array less to read) and the largest step's flight (2 grow).
struct GrownBounds {
  double largest = 0.0;  // as grow_bounds returns it
  double largest_used = 0.0;
  double fastest_step = 0.0;
};
GrownBounds grow_bounds(Particles &p, std::size_t count, const double *extra);
void fly_step(Particles &p, std::size_t count, const Shape &shape, double half_dt);

// Free flight to the midpoint (one or two half steps, as half_step and two_half_steps, with
// the motion constants as they are) and, when the list keeps its watches for these bodies and
// these bounds do not expire it, the detection there, in one parallel region: one fork and
// join per step instead of two, each thread on the same block of bodies in both.
struct MidpointDetection {
  double largest_bound = 0.0;
  bool detected = false;  // else the caller detects (or rebuilds) itself
  DetectionStats stats;
  long long drift_nanoseconds = 0;  // of the whole call, the free flight
};
MidpointDetection advance_to_midpoint(Particles &p, std::size_t count, const Shape &shape,
                                      double half_dt, int halves, NeighborList &list,
                                      const Box &box, std::vector<Contact> &contacts);

}  // namespace hardrod
