// Orthorhombic periodic box. The minimum image is taken through an integer image shift
// (nearbyint of the scaled separation), so the same separation always maps to the same
// image and owners, shadows and any thread count agree bit for bit (SPEC.md section 4, 7).
#pragma once

#include <cmath>

#include "kernels/vec3.hpp"

namespace hardrod {

struct Box {
  Vec3 length{1.0, 1.0, 1.0};

  double volume() const { return length.x * length.y * length.z; }
  double min_side() const { return std::fmin(length.x, std::fmin(length.y, length.z)); }

  // Integer number of box lengths to subtract from a separation to reach its minimum image.
  static double image_shift(double d, double side) { return std::nearbyint(d / side); }

  // Separation a - b reduced to the minimum image.
  Vec3 minimum_image(const Vec3 &d) const {
    return {d.x - image_shift(d.x, length.x) * length.x,
            d.y - image_shift(d.y, length.y) * length.y,
            d.z - image_shift(d.z, length.z) * length.z};
  }

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
