// Kinetic energy and the rescaling thermostat of the paper (docs/physics.md section 2): every
// `thermostat_interval` steps all velocities and angular velocities are scaled by one
// factor so the kinetic energy returns to its target. Sums are exact (ExactSum), so the
// factor has the same bits for any thread count. Element-wise scaling, OpenMP static.
#pragma once

#include <cstddef>

#include "kernels/exact_sum.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

struct KineticEnergy {
  ExactSum translational, rotational;
  double total() const {
    ExactSum t = translational;
    t += rotational;
    return t.value();
  }
  KineticEnergy &operator+=(const KineticEnergy &o) {
    translational += o.translational;
    rotational += o.rotational;
    return *this;
  }
};

KineticEnergy kinetic_energy(const Particles &p, std::size_t count, const Shape &shape);

// Kinetic energy of `n` bodies at temperature kT with zero total momentum:
// (dof n - 3) kT / 2.
double target_kinetic_energy(long long n, const Shape &shape, double kT);

void scale_velocities(Particles &p, std::size_t count, double factor);

}  // namespace hardrod
