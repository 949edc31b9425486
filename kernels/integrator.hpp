// Free flight for half a time step (SPEC.md section 3): x += v dt/2, and the axis turned
// about w by the angle |w| dt/2 (Rodrigues' rotation, exact for a free linear rotor; the
// renormalisation is left to restore_rotor_constraints). Also grows each body's motion
// bound by the largest distance any point of the body can have moved,
// (|v| + L/2 |w|) dt/2, which the lazy pair checks rely on.
// Centres are never folded back into the box: every separation goes through the minimum
// image, and the cell list and the domain fold when they bin, so the trajectory does not
// depend on when anything is folded.
// Reads/writes positions, axes, motion bounds; reads velocities. Element-wise, OpenMP
// static schedule, no reductions: bit-identical for any thread count.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

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
// Returns the largest motion bound of the bodies after the half step.
double half_step(Particles &p, std::size_t count, const Shape &shape, double half_dt);

// Two half steps in one pass over the bodies, bit for bit the same as two calls of
// half_step: the second half of a step fused with the first half of the next, when nothing
// happens between them (no contacts are resolved between the two halves of one pass).
double two_half_steps(Particles &p, std::size_t count, const Shape &shape, double half_dt);

// One or two half steps (`halves`) for bodies [0, count), threads splitting them in team
// blocks above kParallelBodies, with the motion constants as they are (refresh_motion).
double free_flight(Particles &p, std::size_t count, const Shape &shape, double half_dt, int halves);

// One or two half steps (`halves`) for bodies [lo, hi) only, with no threads of its own:
// for a thread of a team that takes the block team_block(...) (particles.hpp), as
// advance_to_midpoint does. Returns the block's largest motion bound. Reads the bodies'
// motion constants: they must be current (refresh_motion).
double drift_block(Particles &p, long lo, long hi, const Shape &shape, double half_dt, int halves);

// Renormalise the axes and remove the component of w along them that rounding introduces
// over many steps, so |e| = 1 and w stays perpendicular to e (every kConstraintInterval
// steps, not every step: the drift is ~1e-16 per step).
void restore_rotor_constraints(Particles &p, std::size_t count);
inline constexpr long long kConstraintInterval = 100;

}  // namespace hardrod
