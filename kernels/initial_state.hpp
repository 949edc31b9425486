// Initial configurations and velocities (docs/physics.md section 2). The lattice puts n bodies on
// an nx x ny x nz grid filling the box, all axes along one coordinate axis. Velocities and
// angular velocities are Gaussian at kT from counter-based draws keyed by body id (so they
// do not depend on the decomposition), w perpendicular to the axis, total momentum zero,
// and the kinetic energy scaled to exactly (dof n - 3) kT / 2. Serial; runs once. The same
// bodies can be made a share at a time (a rank's, without the others: place_lattice_block,
// draw_velocities, and the totals over all shares given to remove_drift and scale_to_target),
// with the same bits: every total is an exact sum.
#pragma once

#include <array>
#include <cstdint>
#include <functional>

#include "kernels/exact_sum.hpp"

#include "kernels/box.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

// Bodies get ids 0..n-1 in x-fastest lattice order.
void place_on_lattice(Particles &p, const Box &box, const std::array<long long, 3> &lattice,
                      int axis);

void assign_velocities(Particles &p, const Shape &shape, std::uint64_t seed, double kT);

// The lattice's sites with indices in [from[a], to[a]) along each axis a that `keep` keeps
// (by centre), appended to p in id order: a share of place_on_lattice's bodies.
void place_lattice_block(Particles &p, const Box &box, const std::array<long long, 3> &lattice,
                         int axis, const std::array<long long, 3> &from,
                         const std::array<long long, 3> &to,
                         const std::function<bool(const Vec3 &)> &keep);

// assign_velocities in parts: the draws of p's bodies, returning their momentum sums (x, y, z);
// then, with the sums over every share, the drift removed (n bodies in all) and the kinetic
// energy (`kinetic`, over every share after remove_drift) scaled to the target.
std::array<ExactSum, 3> draw_velocities(Particles &p, const Shape &shape, std::uint64_t seed,
                                        double kT);
void remove_drift(Particles &p, const std::array<ExactSum, 3> &momentum, long long n);
void scale_to_target(Particles &p, const Shape &shape, double kT, long long n, double kinetic);

}  // namespace hardrod
