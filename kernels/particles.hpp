// Struct-of-arrays storage of the bodies a rank holds. Hot fields are separate arrays so
// the free flight and the pair traversals stream them. Global ids give the canonical order
// that every reduction and every contact list is sorted by (docs/physics.md section 7).
#pragma once

#include <omp.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "kernels/vec3.hpp"

namespace hardrod {

// Below this many bodies the per-step passes (integration, pair filter) run on one thread:
// a parallel region costs about a microsecond. The passes must decide alike: with the
// integration split over two cores and the pair filter on one, every step moved the motion
// bounds of half the bodies from one core's cache to the other's, and two threads ran the
// 2304-rod scene no faster than one.
inline constexpr long kParallelBodies = 2048;

// Threads for a per-step pass over n bodies: all of them above kParallelBodies, else one.
inline int team_threads(long n) { return n > kParallelBodies ? omp_get_max_threads() : 1; }

// The bodies [first, second) that thread `tid` of a team of `team` takes in the per-step
// passes (integration, detection): whole 8-body words, so that two threads' byte flags
// never share a word, and the same block in every pass, so that each thread's bodies stay
// in its core's cache from one pass to the next.
inline std::pair<long, long> team_block(long n, int tid, int team) {
  const long words = (n + 7) / 8;
  return {std::min(n, 8 * (words * tid / team)), std::min(n, 8 * (words * (tid + 1) / team))};
}

struct Particles {
  std::vector<std::int64_t> id;
  std::vector<double> x, y, z;     // centre of mass (not folded: see free_flight.hpp)
  std::vector<double> ex, ey, ez;  // unit axis
  std::vector<double> vx, vy, vz;  // linear velocity
  std::vector<double> wx, wy, wz;  // angular velocity, perpendicular to the axis
  // Upper bound on how far any point of the body has moved since the neighbour list was
  // built (translation plus half length times rotation). Decides when a pair needs a
  // narrow-phase test and when the list expires.
  std::vector<double> motion_bound;
  // Constants of each body's free flight (refresh_motion, free_flight.hpp): how much its
  // motion bound grows per half step, and the two series of its half step's rotation.
  // Functions of v, w, the shape and the half step only, so they are computed when a
  // velocity changes instead of in every half step (two square roots and two series per
  // body); drift_block reads them.
  std::vector<double> grow, turn_sinc, turn_vers;

  std::size_t size() const { return id.size(); }
  // New bodies are zeros.
  void resize(std::size_t n);
  // Reorder the first order.size() bodies: body k of the result is body order[k] of before.
  // Used to sort bodies by cell so that neighbours are neighbours in memory too.
  void permute(const std::vector<std::uint32_t> &order);

  Vec3 position(std::size_t i) const { return {x[i], y[i], z[i]}; }
  Vec3 axis(std::size_t i) const { return {ex[i], ey[i], ez[i]}; }
  Vec3 velocity(std::size_t i) const { return {vx[i], vy[i], vz[i]}; }
  Vec3 angular_velocity(std::size_t i) const { return {wx[i], wy[i], wz[i]}; }
  void set_position(std::size_t i, const Vec3 &p) { x[i] = p.x, y[i] = p.y, z[i] = p.z; }
  void set_axis(std::size_t i, const Vec3 &e) { ex[i] = e.x, ey[i] = e.y, ez[i] = e.z; }
  void set_velocity(std::size_t i, const Vec3 &v) { vx[i] = v.x, vy[i] = v.y, vz[i] = v.z; }
  void set_angular_velocity(std::size_t i, const Vec3 &w) { wx[i] = w.x, wy[i] = w.y, wz[i] = w.z; }
};

// One array of doubles of Particles.
using BodyField = std::vector<double> Particles::*;

// A body's state besides its id: the twelve doubles that define it, in the one order used
// wherever a body is stored, sent, hashed or compared (runtime/body_wire.hpp, checkpoint
// rows, the state checksum, System::verify_bodies). Changing the order changes the
// checksum of every run.
inline constexpr std::array<BodyField, 12> kStateFields = {
    &Particles::x,  &Particles::y,  &Particles::z,  &Particles::ex, &Particles::ey, &Particles::ez,
    &Particles::vx, &Particles::vy, &Particles::vz, &Particles::wx, &Particles::wy, &Particles::wz};

// Derived from the state and recomputed (the motion bound at every rebuild, the motion
// constants when a velocity changes): never stored or sent.
inline constexpr std::array<BodyField, 4> kDerivedFields = {
    &Particles::motion_bound, &Particles::grow, &Particles::turn_sinc, &Particles::turn_vers};

inline void Particles::resize(std::size_t n) {
  for (BodyField f : kStateFields) (this->*f).resize(n, 0.0);
  for (BodyField f : kDerivedFields) (this->*f).resize(n, 0.0);
  id.resize(n, 0);
}

inline void Particles::permute(const std::vector<std::uint32_t> &order) {
  std::vector<double> scratch(order.size());
  const std::size_t m = order.size();
  const std::uint32_t *__restrict from = order.data();
  double *__restrict to = scratch.data();
  const auto reorder = [m, from, to](std::vector<double> &field) {
    double *__restrict v = field.data();
    for (std::size_t k = 0; k < m; ++k) to[k] = v[from[k]];
    std::copy(to, to + m, v);
  };
  for (BodyField f : kStateFields) reorder(this->*f);
  for (BodyField f : kDerivedFields) reorder(this->*f);
  std::vector<std::int64_t> ids(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) ids[k] = id[order[k]];
  std::copy(ids.begin(), ids.end(), id.begin());
}

}  // namespace hardrod
