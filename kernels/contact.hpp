// One contact between two bodies at the midpoint of a time step (docs/physics.md section 4).
// Bodies are ordered canonically: id[i] < id[j]. The normal points from j to i. The lever
// arms enter only through r x n, which for a frictionless contact on a capsule axis is
// s (e x n): perpendicular to the axis, as a linear rotor requires.
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/vec3.hpp"

namespace hardrod {

struct Contact {
  std::uint32_t i = 0, j = 0;  // local body indices, id[i] < id[j]
  std::int64_t id_i = 0, id_j = 0;
  Vec3 normal;                     // unit, from j to i
  Vec3 arm_i, arm_j;               // r_i x n and r_j x n (r = contact point - centre)
  Vec3 separation;                 // x_i - x_j, minimum image (for the collision virial)
  double depth = 0.0;              // D - d, overlap depth
  double inverse_mass = 0.0;       // k = 1/m_i + 1/m_j + |r_i x n|^2/I_i + |r_j x n|^2/I_j
  double approach_velocity = 0.0;  // u before resolution (< 0: approaching)
  double impulse = 0.0;            // accumulated lambda >= 0 along the normal
};

// Canonical order of contacts (and candidates): by (id_i, id_j). Every rank and thread count
// sees the same.
inline constexpr struct CanonicalLess {
  template <class C>
  bool operator()(const C &a, const C &b) const {
    return a.id_i != b.id_i ? a.id_i < b.id_i : a.id_j < b.id_j;
  }
} canonical_less;

}  // namespace hardrod
