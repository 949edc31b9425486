// Short vector loops padded to whole vectors. GCC 12 sets a loop's vector width by its
// narrowest type (with AVX-512: 16 lanes where it reads 32-bit indices, 64 where it writes
// bytes) and runs the iterations past the last whole vector in a scalar remainder. The loops
// that screen a batch's candidates (kernels/exact/step_candidates.cpp) run a few dozen
// iterations, so most of their time went to that remainder. Padded, every iteration runs in
// vector lanes.
#pragma once

#include <cstddef>
#include <cstdint>

namespace hardrod {

// Lanes of a loop over 32-bit indices with AVX-512, and a multiple of narrower widths.
inline constexpr std::size_t kIndexLanes = 16;

// `count` rounded up to whole vectors, the entries [count, padded) copies of entry count - 1
// (room for them is the caller's): a padded iteration does what the one it copies does, and
// its result is not read.
inline std::size_t pad_to_lanes(std::uint32_t *entries, std::size_t count) {
  const std::size_t padded = (count + kIndexLanes - 1) / kIndexLanes * kIndexLanes;
  for (std::size_t k = count; k < padded; ++k) entries[k] = entries[count - 1];
  return padded;
}

}  // namespace hardrod
