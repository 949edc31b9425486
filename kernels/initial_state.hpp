// Initial configurations and velocities (docs/physics.md section 2). The lattice puts n bodies on
// an nx x ny x nz grid filling the box, all axes along one coordinate axis. Velocities and
// angular velocities are Gaussian at kT from counter-based draws keyed by body id (so they
// do not depend on the decomposition), w perpendicular to the axis, total momentum zero,
// and the kinetic energy scaled to exactly (dof n - 3) kT / 2. Serial; runs once.
#pragma once

#include <array>
#include <cstdint>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

// Bodies get ids 0..n-1 in x-fastest lattice order.
void place_on_lattice(Particles &p, const Box &box, const std::array<long long, 3> &lattice,
                      int axis);

void assign_velocities(Particles &p, const Shape &shape, std::uint64_t seed, double kT);

}  // namespace hardrod
