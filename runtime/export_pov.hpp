// `hardrod export ... --format pov`: one frame as a POV-Ray scene (read by Debian's povray;
// `scripts/render` runs both). Each rod is a capsule (an open cylinder between two spheres,
// one #macro call a rod) coloured by the angle between its axis and the director, the
// principal eigenvector of the frame's order tensor (kernels/order_tensor.hpp): 0 deg
// (parallel) to 90 deg (perpendicular) on the scale of angle_colour, shown as a legend bar
// fixed to the camera. The box's twelve edges are thin cylinders; a slab cut keeps only the
// rods whose centres lie in it, so that the inside of a dense box shows. No include files or
// fonts are needed: the legend's digits are drawn from cylinders.
#pragma once

#include <optional>
#include <string>

#include "kernels/shape.hpp"
#include "kernels/vec3.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

// The rods whose centres, folded into the box [0, L), have from <= c < to along `axis`
// (0, 1, 2: x, y, z), in D.
struct PovSlab {
  int axis = 0;
  double from = 0.0;
  double to = 0.0;
};

// "AXIS:FROM:TO", e.g. "x:0:10". Throws std::invalid_argument naming --slab and the value.
PovSlab parse_slab(const std::string &text);

// A colour as sRGB components in [0, 1].
struct Rgb {
  double red = 0.0, green = 0.0, blue = 0.0;
};

// The colour scale: blue at 0 deg (along the director) through sky blue, green and amber to
// red at 90 deg (perpendicular), linear in the angle between its stops; clamped to [0, 90].
Rgb angle_colour(double degrees);

// The angle between a rod's unit axis and the director, in degrees in [0, 90] (a rod and
// its reverse are the same rod).
double angle_to_director(const Vec3 &axis, const Vec3 &director);

// The scene of one frame; `source` (the file and frame) goes into its header comment.
// Throws std::invalid_argument when the slab holds no rod centre.
std::string pov_scene(const SnapshotFrame &frame, const Shape &shape,
                      const std::optional<PovSlab> &slab, const std::string &source);

}  // namespace hardrod
