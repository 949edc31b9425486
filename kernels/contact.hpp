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

// The exact method's candidate (contact_detection.hpp, StepAhead): a listed pair that could touch
// within the step, with what its clusters read (exact_collisions.hpp). 40 bytes where a Contact
// is 152: a step of hard spheres at N = 32768 writes, sorts and reads ~5000 of them.
struct Candidate {
  std::uint32_t i = 0, j = 0;  // local body indices, id[i] < id[j]
  std::int64_t id_i = 0, id_j = 0;
  double depth = 0.0;  // D - d at the step's start (negative: apart)
  // The two free flights alone keep the pair apart all step: its first search would find nothing.
  bool apart = false;
  // Beyond the two free flights' reach, within the overrun allowance only (StepAhead::allowance):
  // a partner for the one queue's predictions after a velocity changes, not a candidate of the
  // free flights (apart too; not counted, and the clusters leave it out).
  bool spare = false;
  // Where apart (or a spare): a lower bound of the pair's surface gap less kApartMargin over the
  // whole step along the two free flights (the screens' bound at its least, or a spare's
  // distance beyond the flights' reach), rounded down to a float (beside the flags, the record
  // stays 40 bytes); else 0. The one queue keeps the pair apart with it after a velocity
  // changes, while it covers how far the new flights can stray (exact_queue.cpp).
  float proven = 0.0f;
};
static_assert(sizeof(Candidate) == 40, "thousands a step are sorted and copied");

// Canonical order of contacts (and candidates): by (id_i, id_j). Every rank and thread count
// sees the same.
inline constexpr struct CanonicalLess {
  template <class C>
  bool operator()(const C &a, const C &b) const {
    return a.id_i != b.id_i ? a.id_i < b.id_i : a.id_j < b.id_j;
  }
} canonical_less;

}  // namespace hardrod
