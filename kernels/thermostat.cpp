#include "kernels/thermostat.hpp"

#include <omp.h>

#include <vector>

namespace hardrod {

KineticEnergy kinetic_energy(const Particles &p, std::size_t count, const Shape &shape) {
  const double inertia = shape.is_sphere() ? 0.0 : shape.inertia_perp();
  const long n = static_cast<long>(count);
  std::vector<KineticEnergy> part(omp_get_max_threads());
#pragma omp parallel
  {
    // Summed here and stored once: the threads' entries of `part` share cache lines.
    KineticEnergy mine;
#pragma omp for schedule(static)
    for (long i = 0; i < n; ++i) {
      mine.translational.add(0.5 * shape.mass *
                             (p.vx[i] * p.vx[i] + p.vy[i] * p.vy[i] + p.vz[i] * p.vz[i]));
      if (inertia > 0.0)
        mine.rotational.add(0.5 * inertia *
                            (p.wx[i] * p.wx[i] + p.wy[i] * p.wy[i] + p.wz[i] * p.wz[i]));
    }
    part[omp_get_thread_num()] = mine;
  }
  KineticEnergy total;
  for (const auto &k : part) total += k;
  return total;
}

double target_kinetic_energy(long long n, const Shape &shape, double kT) {
  return 0.5 * kT * static_cast<double>(shape.degrees_of_freedom() * n - 3);
}

void scale_velocities(Particles &p, std::size_t count, double factor) {
  const long n = static_cast<long>(count);
#pragma omp parallel for schedule(static)
  for (long i = 0; i < n; ++i) {
    p.vx[i] *= factor;
    p.vy[i] *= factor;
    p.vz[i] *= factor;
    p.wx[i] *= factor;
    p.wy[i] *= factor;
    p.wz[i] *= factor;
  }
}

}  // namespace hardrod
