// Struct-of-arrays storage of the bodies a rank holds. Hot fields are separate arrays so
// the integrator and the pair traversals stream them. Global ids give the canonical order
// that every reduction and every contact list is sorted by (SPEC.md section 7).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/vec3.hpp"

namespace hardrod {

struct Particles {
  std::vector<std::int64_t> id;
  std::vector<double> x, y, z;     // centre of mass, folded into the box
  std::vector<double> ex, ey, ez;  // unit axis
  std::vector<double> vx, vy, vz;  // linear velocity
  std::vector<double> wx, wy, wz;  // angular velocity, perpendicular to the axis
  // Upper bound on how far any point of the body has moved since the neighbour list was
  // built (translation plus half length times rotation). Drives the lazy pair checks.
  std::vector<double> motion_bound;

  std::size_t size() const { return id.size(); }
  void resize(std::size_t n) {
    for (auto *v : {&x, &y, &z, &ex, &ey, &ez, &vx, &vy, &vz, &wx, &wy, &wz, &motion_bound})
      v->resize(n, 0.0);
    id.resize(n, 0);
  }

  Vec3 position(std::size_t i) const { return {x[i], y[i], z[i]}; }
  Vec3 axis(std::size_t i) const { return {ex[i], ey[i], ez[i]}; }
  Vec3 velocity(std::size_t i) const { return {vx[i], vy[i], vz[i]}; }
  Vec3 angular_velocity(std::size_t i) const { return {wx[i], wy[i], wz[i]}; }
  void set_position(std::size_t i, const Vec3 &p) { x[i] = p.x, y[i] = p.y, z[i] = p.z; }
  void set_axis(std::size_t i, const Vec3 &e) { ex[i] = e.x, ey[i] = e.y, ez[i] = e.z; }
  void set_velocity(std::size_t i, const Vec3 &v) { vx[i] = v.x, vy[i] = v.y, vz[i] = v.z; }
  void set_angular_velocity(std::size_t i, const Vec3 &w) { wx[i] = w.x, wy[i] = w.y, wz[i] = w.z; }
};

}  // namespace hardrod
