// The rotor constraints (phase 7 of the step, runtime/system.hpp); the free flight itself
// is kernels/free_flight.hpp. The rotation of the free flight keeps |e| = 1 and w perpendicular to
// e only to round-off (~1e-16 per step); restore_rotor_constraints removes that drift. After it the
// velocities have changed: refresh_motion (free_flight.hpp) before the next drift. Element-wise,
// OpenMP static schedule: bit-identical for any thread count.
#pragma once

#include <cstddef>

#include "kernels/particles.hpp"

namespace hardrod {

// Renormalise the axes and remove the component of w along them that rounding introduces
// over many steps, so |e| = 1 and w stays perpendicular to e (every kConstraintInterval
// steps, not every step: the drift is ~1e-16 per step).
void restore_rotor_constraints(Particles &p, std::size_t count);
inline constexpr long long kConstraintInterval = 100;

}  // namespace hardrod
