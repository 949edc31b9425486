// Free flight for half a time step (SPEC.md section 3): x += v dt/2, and the axis turned
// about w by the angle |w| dt/2 (Rodrigues' rotation, exact for a free linear rotor), then
// renormalised. Also grows each body's motion bound by the largest distance any point of
// the body can have moved, (|v| + L/2 |w|) dt/2, which the lazy pair checks rely on.
// Reads/writes positions, axes, motion bounds; reads velocities. Element-wise, OpenMP
// static schedule, no reductions: bit-identical for any thread count.
#pragma once

#include <cstddef>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

// With `fold` given, centres that left [0, L) are folded back by whole box lengths.
void half_step(Particles &p, std::size_t count, const Shape &shape, double half_dt,
               const Box *fold = nullptr);

// Remove the component of w along the axis that rounding may have introduced over many
// steps, so w stays perpendicular to e (called with the thermostat, not every step).
void project_angular_velocities(Particles &p, std::size_t count);

}  // namespace hardrod
