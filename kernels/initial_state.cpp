#include "kernels/initial_state.hpp"

#include <cmath>

#include "kernels/exact_sum.hpp"
#include "kernels/random.hpp"
#include "kernels/thermostat.hpp"

namespace hardrod {

void place_on_lattice(Particles &p, const Box &box, const std::array<long long, 3> &lattice,
                      int axis) {
  const long long n = lattice[0] * lattice[1] * lattice[2];
  p.resize(static_cast<std::size_t>(n));
  const Vec3 spacing{box.length.x / static_cast<double>(lattice[0]),
                     box.length.y / static_cast<double>(lattice[1]),
                     box.length.z / static_cast<double>(lattice[2])};
  const Vec3 e{axis == 0 ? 1.0 : 0.0, axis == 1 ? 1.0 : 0.0, axis == 2 ? 1.0 : 0.0};
  std::size_t k = 0;
  for (long long iz = 0; iz < lattice[2]; ++iz)
    for (long long iy = 0; iy < lattice[1]; ++iy)
      for (long long ix = 0; ix < lattice[0]; ++ix, ++k) {
        p.id[k] = static_cast<std::int64_t>(k);
        p.set_position(k, {(static_cast<double>(ix) + 0.5) * spacing.x,
                           (static_cast<double>(iy) + 0.5) * spacing.y,
                           (static_cast<double>(iz) + 0.5) * spacing.z});
        p.set_axis(k, e);
        p.motion_bound[k] = 0.0;
      }
}

void assign_velocities(Particles &p, const Shape &shape, std::uint64_t seed, double kT) {
  const std::size_t n = p.size();
  const double sigma_v = std::sqrt(kT / shape.mass);
  const double sigma_w = shape.is_sphere() ? 0.0 : std::sqrt(kT / shape.inertia_perp());
  ExactSum px, py, pz;
  for (std::size_t i = 0; i < n; ++i) {
    const auto id = static_cast<std::uint64_t>(p.id[i]);
    CounterRandom rv(seed, RandomPurpose::kVelocity, id);
    const Vec3 v{sigma_v * rv.normal(), sigma_v * rv.normal(), sigma_v * rv.normal()};
    p.set_velocity(i, v);
    px.add(v.x);
    py.add(v.y);
    pz.add(v.z);
    CounterRandom rw(seed, RandomPurpose::kAngularVelocity, id);
    Vec3 w{sigma_w * rw.normal(), sigma_w * rw.normal(), sigma_w * rw.normal()};
    const Vec3 e = p.axis(i);
    w -= dot(w, e) * e;  // a linear rotor spins only about axes perpendicular to e
    p.set_angular_velocity(i, w);
  }
  const double inv_n = 1.0 / static_cast<double>(n);
  const Vec3 drift{px.value() * inv_n, py.value() * inv_n, pz.value() * inv_n};
  for (std::size_t i = 0; i < n; ++i) p.set_velocity(i, p.velocity(i) - drift);
  const double target = target_kinetic_energy(static_cast<long long>(n), shape, kT);
  const double current = kinetic_energy(p, n, shape).total();
  if (current > 0.0) scale_velocities(p, n, std::sqrt(target / current));
}

}  // namespace hardrod
