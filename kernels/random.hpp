// Counter-based random numbers keyed by (seed, purpose, body id, draw index), so a body's
// random draws do not depend on which rank or thread makes them, or in which order
// (HOOMD-blue's habit). The mixer is SplitMix64's finaliser applied in a chain; it is not
// cryptographic, but passes the statistical needs of initial velocities.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>

namespace hardrod {

enum class RandomPurpose : std::uint64_t { kVelocity = 1, kAngularVelocity = 2, kPlacement = 3 };

inline std::uint64_t mix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

class CounterRandom {
 public:
  CounterRandom(std::uint64_t seed, RandomPurpose purpose, std::uint64_t id)
      : key_(mix64(mix64(mix64(seed) ^ static_cast<std::uint64_t>(purpose)) ^ id)) {}

  std::uint64_t next_u64() { return mix64(key_ ^ mix64(counter_++)); }
  // Uniform in (0, 1): never exactly 0, so log() in Box-Muller is finite.
  double uniform() { return (static_cast<double>(next_u64() >> 11) + 0.5) * 0x1.0p-53; }
  double normal() {
    const double u1 = uniform();
    const double u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::uint64_t key_;
  std::uint64_t counter_ = 0;
};

}  // namespace hardrod
