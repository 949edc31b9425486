// One frame as a POV-Ray scene (runtime/export_pov.hpp). The scene is plain POV-Ray 3.7 SDL:
// no include files (Debian's povray comes without them), one texture per whole degree of the
// colour scale, one macro call per rod. The camera is framed in the scene's own arithmetic
// from image_width and image_height, so one .pov file renders well at any --size.
#include "runtime/export_pov.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <numbers>
#include <stdexcept>
#include <vector>

#include "kernels/order_tensor.hpp"

namespace hardrod {

namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// The scale's stops, every 22.5 deg from 0 (parallel) to 90 (perpendicular).
constexpr std::array<Rgb, 5> kStops = {{{0.19, 0.27, 0.80},
                                        {0.10, 0.65, 0.90},
                                        {0.35, 0.80, 0.35},
                                        {0.98, 0.72, 0.15},
                                        {0.85, 0.15, 0.12}}};

// Where the camera is and where it looks: `side` points from the box's centre towards the
// camera, `sky` is up in the picture.
struct View {
  Vec3 side, sky;
};

Vec3 unit(const Vec3 &v) { return (1.0 / norm(v)) * v; }

Vec3 axis_vector(int axis) {
  return {axis == 0 ? 1.0 : 0.0, axis == 1 ? 1.0 : 0.0, axis == 2 ? 1.0 : 0.0};
}

// Without a slab the rods are seen from the side that the director lies across (a nematic
// shows its rods' length, not their ends), turned 30 deg and raised 25 deg so that three faces
// of the box show; with a slab the camera faces the slab, turned 20 deg and raised 15 deg.
View choose_view(const Vec3 &director, const std::optional<PovSlab> &slab) {
  Vec3 side{0.0, -1.0, 0.0}, sky{0.0, 0.0, 1.0};
  double turn = 30.0, rise = 25.0;
  if (slab) {
    side = slab->axis == 1 ? Vec3{0.0, -1.0, 0.0} : axis_vector(slab->axis);
    if (slab->axis == 2) sky = {0.0, 1.0, 0.0};
    turn = 20.0, rise = 15.0;
  } else if (std::fabs(director.y) > std::fabs(director.x)) {
    side = {1.0, 0.0, 0.0};
  }
  const Vec3 turned = std::cos(turn * kDegree) * side + std::sin(turn * kDegree) * cross(sky, side);
  return {unit(std::cos(rise * kDegree) * turned + std::sin(rise * kDegree) * sky), sky};
}

std::string vec(const Vec3 &v) { return fmt::format("<{:.12g}, {:.12g}, {:.12g}>", v.x, v.y, v.z); }

std::string srgb(const Rgb &c) {
  return fmt::format("srgb <{:.4f}, {:.4f}, {:.4f}>", c.red, c.green, c.blue);
}

// The extent of the box (grown by `margin`) on the picture, seen from `location` along
// `forward`: x along `right`, y along `up`, in picture heights for a direction of length
// `focal`.
struct Extent {
  double x_low = 1e300, x_high = -1e300, y_low = 1e300, y_high = -1e300;
};

Extent project_box(const Box &box, double margin, const Vec3 &location, const Vec3 &forward,
                   const Vec3 &right, const Vec3 &up, double focal) {
  Extent e;
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 p{corner & 1 ? box.length.x + margin : -margin,
                 corner & 2 ? box.length.y + margin : -margin,
                 corner & 4 ? box.length.z + margin : -margin};
    const Vec3 d = p - location;
    const double depth = dot(d, forward) / focal;
    const double sx = dot(d, right) / depth, sy = dot(d, up) / depth;
    e.x_low = std::min(e.x_low, sx), e.x_high = std::max(e.x_high, sx);
    e.y_low = std::min(e.y_low, sy), e.y_high = std::max(e.y_high, sy);
  }
  return e;
}

// The camera: looking along -side from a distance at which the box, and the rods that stick
// out of it, fill the picture above the legend (y from -0.36 to 0.47 of its height). The
// box's corners are projected here at the distance that fits a 4:3 picture; for another
// aspect the scene scales that distance by how much the projection is too large or too small
// for its room, and every picture shifts the camera to centre the projection there.
std::string camera_section(const Box &box, double margin, const View &view) {
  constexpr double kFocal = 1.6;  // the direction's length for an up of 1: 35 deg of height
  constexpr double kHalfHeight = 0.415, kLift = 0.055, kHalfWidth = 0.47;
  const Vec3 centre = 0.5 * box.length;
  const Vec3 forward = -view.side;
  const Vec3 right = unit(cross(forward, view.sky));
  const Vec3 up = cross(right, forward);
  double distance = 2.5 * norm(box.length);
  Extent e;
  for (int pass = 0; pass < 3; ++pass) {  // perspective: the fit moves the projection a little
    e = project_box(box, margin, centre - distance * forward, forward, right, up, kFocal);
    distance *= std::max(0.5 * (e.y_high - e.y_low) / kHalfHeight,
                         0.5 * (e.x_high - e.x_low) / (kHalfWidth * 4.0 / 3.0));
  }
  e = project_box(box, margin, centre - distance * forward, forward, right, up, kFocal);
  const double world_per_height = distance / kFocal;  // at the centre's depth
  return fmt::format(
      "// The box's projection at distance {d:.8g}: {hx:.8g} picture heights wide and {hy:.8g} "
      "high (half);\n"
      "// the distance is scaled so that it fits above the legend.\n"
      "#declare Aspect = image_width / image_height;\n"
      "#declare Scale = max({hy:.8g} / {room_y}, {hx:.8g} / ({room_x} * Aspect));\n"
      "#declare Forward = {f};\n#declare Right = {r};\n#declare Up = {u};\n"
      "#declare Focal = {focal};\n"
      "#declare CameraAt = {c} - Forward * Scale * {d:.8g}\n"
      "  + Right * Scale * {cx:.8g} + Up * Scale * {cy:.8g};\n"
      "camera {{ perspective location CameraAt direction Focal * Forward\n"
      "  right Aspect * Right up Up }}\n"
      "light_source {{ CameraAt + Scale * {d:.8g} * (0.6 * Up - 0.5 * Right) srgb 0.9 }}\n"
      "light_source {{ CameraAt srgb 0.35 shadowless }}\n\n",
      fmt::arg("d", distance), fmt::arg("hx", 0.5 * (e.x_high - e.x_low)),
      fmt::arg("hy", 0.5 * (e.y_high - e.y_low)), fmt::arg("room_y", kHalfHeight),
      fmt::arg("room_x", kHalfWidth), fmt::arg("f", vec(forward)), fmt::arg("r", vec(right)),
      fmt::arg("u", vec(up)), fmt::arg("focal", kFocal), fmt::arg("c", vec(centre)),
      fmt::arg("cx", 0.5 * (e.x_high + e.x_low) * world_per_height),
      fmt::arg("cy", (0.5 * (e.y_high + e.y_low) - kLift) * world_per_height));
}

// The twelve edges of the box, as cylinders with rounded corners.
std::string box_section(const Box &box) {
  const Vec3 &l = box.length;
  const double r = std::max(0.05, 0.004 * std::max({l.x, l.y, l.z}));
  std::string out = fmt::format("// The box's edges.\nunion {{\n");
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3 p{corner & 1 ? l.x : 0.0, corner & 2 ? l.y : 0.0, corner & 4 ? l.z : 0.0};
    out += fmt::format("  sphere {{ {}, {:.4g} }}\n", vec(p), r);
    for (int axis = 0; axis < 3; ++axis) {
      if (corner & (1 << axis)) continue;  // each edge once, from its lower end
      const Vec3 q{axis == 0 ? l.x : p.x, axis == 1 ? l.y : p.y, axis == 2 ? l.z : p.z};
      out += fmt::format("  cylinder {{ {}, {}, {:.4g} open }}\n", vec(p), vec(q), r);
    }
  }
  return out + "  pigment { srgb 0.25 } finish { ambient 0.3 diffuse 0.6 }\n}\n\n";
}

// Seven-segment glyphs (segments a..g: top, upper right, lower right, bottom, lower left,
// upper left, middle) for the legend's digits, in a cell 0.55 wide and 1 high.
constexpr std::array<const char *, 10> kDigitSegments = {
    "abcdef", "bc", "abged", "abgcd", "fgbc", "afgcd", "afgedc", "abc", "abcdefg", "abcdfg"};

std::string segment(char s, double x, double y, double h) {
  const double w = 0.55 * h;
  struct Ends {
    double x0, y0, x1, y1;
  };
  const Ends e = s == 'a'   ? Ends{0, 1, 1, 1}
                 : s == 'b' ? Ends{1, 1, 1, 0.5}
                 : s == 'c' ? Ends{1, 0.5, 1, 0}
                 : s == 'd' ? Ends{0, 0, 1, 0}
                 : s == 'e' ? Ends{0, 0, 0, 0.5}
                 : s == 'f' ? Ends{0, 0.5, 0, 1}
                            : Ends{0, 0.5, 1, 0.5};
  return fmt::format("  Seg({:.4f}, {:.4f}, {:.4f}, {:.4f})\n", x + e.x0 * w, y + e.y0 * h,
                     x + e.x1 * w, y + e.y1 * h);
}

// `degrees` as digits and a degree ring, centred on x, from y up, `h` high.
std::string angle_label(int degrees, double x, double y, double h) {
  const std::string digits = std::to_string(degrees);
  const double advance = 0.85 * h, ring = 0.16 * h;
  const double width = static_cast<double>(digits.size()) * advance + 2.5 * ring;
  double at = x - 0.5 * width;
  std::string out;
  for (char c : digits) {
    for (const char *s = kDigitSegments[static_cast<std::size_t>(c - '0')]; *s; ++s)
      out += segment(*s, at, y, h);
    at += advance;
  }
  out += fmt::format("  torus {{ {:.4f}, {:.4f} rotate x * 90 translate <{:.4f}, {:.4f}, 0> }}\n",
                     ring, 0.05 * h, at + ring, y + h - ring);
  return out;
}

// The colour scale as a bar at the bottom of the picture, labelled 0, 45 and 90 deg, fixed
// to the camera: local x is the picture's right and y its up, in picture heights, at a depth
// nearer than anything in the box. Lit by nothing (ambient only) and casting no shadow.
std::string legend_section() {
  std::string out =
      "// The colour scale: angle between a rod's axis and the director, 0 to 90 deg.\n"
      "#declare LegendDepth = 0.05;\n"
      "#macro Seg(X0, Y0, X1, Y1)\n"
      "  cylinder { <X0, Y0, 0>, <X1, Y1, 0>, 0.0025 } sphere { <X0, Y0, 0>, 0.0025 }\n"
      "  sphere { <X1, Y1, 0>, 0.0025 }\n"
      "#end\n"
      "union {\n"
      "  box { <0.0005, 0, 0>, <0.9995, 1, 0.001>\n"
      "    texture { pigment { gradient x color_map {\n";
  for (int d = 0; d <= 90; d += 3)
    out += fmt::format("      [{:.4f} {}]\n", d / 90.0, srgb(angle_colour(d)));
  out +=
      "    } } finish { ambient 1 diffuse 0 } }\n"
      "    scale <0.5, 0.028, 1> translate <-0.25, -0.40, 0> }\n"
      "  union {\n"
      "    Seg(-0.25, -0.40, 0.25, -0.40) Seg(0.25, -0.40, 0.25, -0.372)\n"
      "    Seg(0.25, -0.372, -0.25, -0.372) Seg(-0.25, -0.372, -0.25, -0.40)\n"
      "    Seg(0, -0.40, 0, -0.41)\n";
  out += angle_label(0, -0.25, -0.455, 0.036);
  out += angle_label(45, 0.0, -0.455, 0.036);
  out += angle_label(90, 0.25, -0.455, 0.036);
  out +=
      "    texture { pigment { srgb 0.1 } finish { ambient 1 diffuse 0 } }\n"
      "  }\n"
      "  no_shadow\n"
      "  matrix < Right.x * LegendDepth, Right.y * LegendDepth, Right.z * LegendDepth,\n"
      "           Up.x * LegendDepth, Up.y * LegendDepth, Up.z * LegendDepth,\n"
      "           Forward.x * LegendDepth, Forward.y * LegendDepth, Forward.z * LegendDepth,\n"
      "           CameraAt.x + LegendDepth * Focal * Forward.x,\n"
      "           CameraAt.y + LegendDepth * Focal * Forward.y,\n"
      "           CameraAt.z + LegendDepth * Focal * Forward.z >\n"
      "}\n\n";
  return out;
}

// The textures, one a degree, and the rod macro R(x, y, z, ex, ey, ez, degree).
std::string rod_definitions(const Shape &shape) {
  std::string out = fmt::format(
      "#declare Radius = {:.6g};\n#declare Half = {:.6g};\n"
      "#declare RodFinish = finish {{ ambient 0.2 diffuse 0.75 specular 0.3 roughness 0.02 }}\n"
      "#declare Colour = array[91] {{\n",
      shape.radius(), shape.half_length());
  for (int d = 0; d <= 90; ++d)
    out += fmt::format("  texture {{ pigment {{ {} }} finish {{ RodFinish }} }}{}\n",
                       srgb(angle_colour(d)), d < 90 ? "," : "");
  out += "}\n";
  if (shape.is_sphere())  // a zero-length cylinder is an error in POV-Ray
    return out +
           "#macro R(X, Y, Z, EX, EY, EZ, K)\n"
           "  sphere { <X, Y, Z>, Radius texture { Colour[K] } }\n"
           "#end\n\n";
  return out +
         "#macro R(X, Y, Z, EX, EY, EZ, K)\n"
         "  #local C = <X, Y, Z>;\n"
         "  #local H = Half * <EX, EY, EZ>;\n"
         "  union {\n"
         "    cylinder { C - H, C + H, Radius open }\n"
         "    sphere { C - H, Radius } sphere { C + H, Radius }\n"
         "    texture { Colour[K] }\n"
         "  }\n"
         "#end\n\n";
}

}  // namespace

PovSlab parse_slab(const std::string &text) {
  const auto refuse = [&text](const std::string &why) {
    return std::invalid_argument(fmt::format("--slab {}: {}", text, why));
  };
  const std::size_t first = text.find(':');
  const std::size_t second = first == std::string::npos ? first : text.find(':', first + 1);
  if (second == std::string::npos || text.find(':', second + 1) != std::string::npos)
    throw refuse("must look like x:0:10 (AXIS:FROM:TO, in D)");
  const std::string axis = text.substr(0, first);
  PovSlab slab;
  if (axis == "x" || axis == "y" || axis == "z")
    slab.axis = axis[0] - 'x';
  else
    throw refuse("the axis must be x, y or z");
  const auto number = [&](const std::string &part) {
    std::size_t used = 0;
    double v = NAN;
    try {
      v = std::stod(part, &used);
    } catch (const std::exception &) {
      used = 0;
    }
    if (used == 0 || used != part.size() || !std::isfinite(v))
      throw refuse(fmt::format("'{}' is not a number", part));
    return v;
  };
  slab.from = number(text.substr(first + 1, second - first - 1));
  slab.to = number(text.substr(second + 1));
  if (!(slab.from < slab.to)) throw refuse("FROM must be less than TO");
  return slab;
}

Rgb angle_colour(double degrees) {
  const double t = std::clamp(degrees, 0.0, 90.0) / 90.0 * (kStops.size() - 1);
  const std::size_t k = std::min(static_cast<std::size_t>(t), kStops.size() - 2);
  const double f = t - static_cast<double>(k);
  const Rgb &a = kStops[k], &b = kStops[k + 1];
  return {a.red + f * (b.red - a.red), a.green + f * (b.green - a.green),
          a.blue + f * (b.blue - a.blue)};
}

double angle_to_director(const Vec3 &axis, const Vec3 &director) {
  return std::acos(std::min(1.0, std::fabs(dot(axis, director)))) / kDegree;
}

std::string pov_scene(const SnapshotFrame &f, const Shape &shape,
                      const std::optional<PovSlab> &slab, const std::string &source) {
  const Particles &p = f.bodies;
  const OrderParameter order = order_parameter(axis_moments(p, p.size()));
  std::vector<std::size_t> shown;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Vec3 c = f.box.wrap(p.position(i));
    const double along = slab ? (slab->axis == 0 ? c.x : slab->axis == 1 ? c.y : c.z) : 0.0;
    if (!slab || (along >= slab->from && along < slab->to)) shown.push_back(i);
  }
  if (shown.empty()) {
    const double side = slab->axis == 0   ? f.box.length.x
                        : slab->axis == 1 ? f.box.length.y
                                          : f.box.length.z;
    throw std::invalid_argument(
        fmt::format("--slab {}:{}:{}: no rod centre lies in it (the box is 0 to {:.6g} D along {})",
                    "xyz"[slab->axis], slab -> from, slab -> to, side, "xyz"[slab->axis]));
  }
  std::string out = fmt::format(
      "// hardrod export: {}, step {}: {} of {} rods{}; S = {:.4f}, director <{:.4f}, {:.4f}, "
      "{:.4f}>\n"
      "// Rods coloured by the angle between axis and director (0 deg blue, 90 deg red).\n"
      "// Render: povray +W1200 +H900 +A0.3 -D +I<this file> +O<picture.png>\n"
      "#version 3.7;\n"
      "global_settings {{ assumed_gamma 1.0 max_trace_level 5 }}\n"
      "background {{ srgb 1 }}\n\n",
      source, f.step, shown.size(), p.size(),
      slab ? fmt::format(" (centres with {} in [{}, {}) D)", "xyz"[slab->axis], slab -> from,
                         slab -> to)
           : std::string(),
      order.S, order.director.x, order.director.y, order.director.z);
  // Room for half of what a rod may stick out of the box: the picture's edge may cut a few.
  out += camera_section(f.box, 0.5 * (shape.half_length() + shape.radius()),
                        choose_view(order.director, slab));
  out += box_section(f.box);
  out += legend_section();
  out += rod_definitions(shape);
  out += "union {\n";
  auto sink = std::back_inserter(out);
  for (std::size_t i : shown) {
    const Vec3 c = f.box.wrap(p.position(i)), e = p.axis(i);
    const long degree = std::lround(angle_to_director(e, order.director));
    fmt::format_to(sink, "R({:.3f},{:.3f},{:.3f},{:.4f},{:.4f},{:.4f},{})\n", c.x, c.y, c.z, e.x,
                   e.y, e.z, degree);
  }
  return out + "}\n";
}

}  // namespace hardrod
