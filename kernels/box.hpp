// Orthorhombic periodic box. The minimum image is taken through an integer image shift
// (nearbyint of the scaled separation), so the same separation always maps to the same
// image and owners, shadows and any thread count agree bit for bit (docs/physics.md section 4, 7).
#pragma once

#include <cmath>

#include "kernels/vec3.hpp"

namespace hardrod {

struct Box {
  Vec3 length{1.0, 1.0, 1.0};

  double volume() const { return length.x * length.y * length.z; }
  double min_side() const { return std::fmin(length.x, std::fmin(length.y, length.z)); }

  Vec3 inverse_length() const { return {1.0 / length.x, 1.0 / length.y, 1.0 / length.z}; }

  // Separation a - b reduced to the minimum image. Hot loops pass the precomputed inverse
  // lengths; every caller uses the same arithmetic, so the same separation always gets the
  // same integer shift.
  Vec3 minimum_image(const Vec3 &d, const Vec3 &inverse) const {
    return {d.x - std::nearbyint(d.x * inverse.x) * length.x,
            d.y - std::nearbyint(d.y * inverse.y) * length.y,
            d.z - std::nearbyint(d.z * inverse.z) * length.z};
  }
  Vec3 minimum_image(const Vec3 &d) const { return minimum_image(d, inverse_length()); }

  // Coordinate folded into [0, side). Only subtracts whole box lengths.
  static double wrap(double c, double side) {
    const double shifted = c - std::floor(c / side) * side;
    return shifted >= side ? shifted - side : shifted;  // floor rounding at the upper edge
  }
  Vec3 wrap(const Vec3 &p) const {
    return {wrap(p.x, length.x), wrap(p.y, length.y), wrap(p.z, length.z)};
  }
};

}  // namespace hardrod
