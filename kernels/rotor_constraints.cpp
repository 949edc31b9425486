// The rotor constraints (see the header).
#include "kernels/rotor_constraints.hpp"

#include <cmath>

namespace hardrod {

void restore_rotor_constraints(Particles &p, std::size_t count) {
  const long n = static_cast<long>(count);
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) {
    const double inv = 1.0 / std::sqrt(p.ex[i] * p.ex[i] + p.ey[i] * p.ey[i] + p.ez[i] * p.ez[i]);
    p.ex[i] *= inv;
    p.ey[i] *= inv;
    p.ez[i] *= inv;
    const double along = p.wx[i] * p.ex[i] + p.wy[i] * p.ey[i] + p.wz[i] * p.ez[i];
    p.wx[i] -= along * p.ex[i];
    p.wy[i] -= along * p.ey[i];
    p.wz[i] -= along * p.ez[i];
  }
}

}  // namespace hardrod
