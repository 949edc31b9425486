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

void place_lattice_block(Particles &p, const Box &box, const std::array<long long, 3> &lattice,
                         int axis, const std::array<long long, 3> &from,
                         const std::array<long long, 3> &to,
                         const std::function<bool(const Vec3 &)> &keep) {
  const Vec3 spacing{box.length.x / static_cast<double>(lattice[0]),
                     box.length.y / static_cast<double>(lattice[1]),
                     box.length.z / static_cast<double>(lattice[2])};
  const Vec3 e{axis == 0 ? 1.0 : 0.0, axis == 1 ? 1.0 : 0.0, axis == 2 ? 1.0 : 0.0};
  for (long long iz = from[2]; iz < to[2]; ++iz)
    for (long long iy = from[1]; iy < to[1]; ++iy)
      for (long long ix = from[0]; ix < to[0]; ++ix) {
        // As place_on_lattice computes it.
        const Vec3 x{(static_cast<double>(ix) + 0.5) * spacing.x,
                     (static_cast<double>(iy) + 0.5) * spacing.y,
                     (static_cast<double>(iz) + 0.5) * spacing.z};
        if (!keep(x)) continue;
        const std::size_t k = p.size();
        p.resize(k + 1);
        p.id[k] = static_cast<std::int64_t>(ix + lattice[0] * (iy + lattice[1] * iz));
        p.set_position(k, x);
        p.set_axis(k, e);
        p.motion_bound[k] = 0.0;
      }
}

std::array<ExactSum, 3> draw_velocities(Particles &p, const Shape &shape, std::uint64_t seed,
                                        double kT) {
  const std::size_t n = p.size();
  const double sigma_v = std::sqrt(kT / shape.mass);
  const double sigma_w = shape.is_sphere() ? 0.0 : std::sqrt(kT / shape.inertia_perp());
  std::array<ExactSum, 3> momentum;
  for (std::size_t i = 0; i < n; ++i) {
    const auto id = static_cast<std::uint64_t>(p.id[i]);
    CounterRandom rv(seed, RandomPurpose::kVelocity, id);
    const Vec3 v{sigma_v * rv.normal(), sigma_v * rv.normal(), sigma_v * rv.normal()};
    p.set_velocity(i, v);
    momentum[0].add(v.x);
    momentum[1].add(v.y);
    momentum[2].add(v.z);
    CounterRandom rw(seed, RandomPurpose::kAngularVelocity, id);
    Vec3 w{sigma_w * rw.normal(), sigma_w * rw.normal(), sigma_w * rw.normal()};
    const Vec3 e = p.axis(i);
    w -= dot(w, e) * e;  // a linear rotor spins only about axes perpendicular to e
    p.set_angular_velocity(i, w);
  }
  return momentum;
}

void remove_drift(Particles &p, const std::array<ExactSum, 3> &momentum, long long n) {
  const double inv_n = 1.0 / static_cast<double>(n);
  const Vec3 drift{momentum[0].value() * inv_n, momentum[1].value() * inv_n,
                   momentum[2].value() * inv_n};
  for (std::size_t i = 0; i < p.size(); ++i) p.set_velocity(i, p.velocity(i) - drift);
}

void scale_to_target(Particles &p, const Shape &shape, double kT, long long n, double kinetic) {
  const double target = target_kinetic_energy(n, shape, kT);
  if (kinetic > 0.0) scale_velocities(p, p.size(), std::sqrt(target / kinetic));
}

void assign_velocities(Particles &p, const Shape &shape, std::uint64_t seed, double kT) {
  const auto n = static_cast<long long>(p.size());
  remove_drift(p, draw_velocities(p, shape, seed, kT), n);
  scale_to_target(p, shape, kT, n, kinetic_energy(p, p.size(), shape).total());
}

}  // namespace hardrod
