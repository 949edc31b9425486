// Random bodies for the detection tests (tests/kernels/test_detection.cpp,
// tests/kernels/exact/test_step_candidates.cpp).
#pragma once

#include <cstdint>
#include <random>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"

namespace hardrod::testing {

// Random gas with some overlaps; velocities random so bodies drift through contacts.
inline Particles random_gas(std::size_t n, const Box &box, std::uint64_t seed, bool aligned) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  Particles p;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(n - i) * 7;  // ids not in storage order
    p.set_position(i, {u(rng) * box.length.x, u(rng) * box.length.y, u(rng) * box.length.z});
    Vec3 e = aligned ? Vec3{1.0, 0.2 * g(rng), 0.2 * g(rng)} : Vec3{g(rng), g(rng), g(rng)};
    p.set_axis(i, (1.0 / norm(e)) * e);
    p.set_velocity(i, {g(rng), g(rng), g(rng)});
    Vec3 w{g(rng), g(rng), g(rng)};
    w -= dot(w, p.axis(i)) * p.axis(i);
    p.set_angular_velocity(i, w);
  }
  return p;
}

}  // namespace hardrod::testing
