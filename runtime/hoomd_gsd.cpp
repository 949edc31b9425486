// hardrod's bodies in HOOMD's GSD schema: the rotations, the frame writer and the frame reader
// (conventions in runtime/hoomd_gsd.hpp).
#include "runtime/hoomd_gsd.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <vector>

#include "runtime/gsd_reader.hpp"

namespace hardrod {

namespace {

Quaternion multiply(const Quaternion &a, const Quaternion &b) {
  return {a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
          a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
          a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
          a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0]};
}
Quaternion conjugate(const Quaternion &q) { return {q[0], -q[1], -q[2], -q[3]}; }
Quaternion normalised(const Quaternion &q) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  return {q[0] / n, q[1] / n, q[2] / n, q[3] / n};
}
Quaternion pure(const Vec3 &v) { return {0.0, v.x, v.y, v.z}; }
Vec3 vector_part(const Quaternion &q) { return {q[1], q[2], q[3]}; }

}  // namespace

Quaternion quaternion_from_axis(const Vec3 &e) {
  // q ~ (1 + e_z, z x e) = (1 + e_z, -e_y, e_x, 0): half the angle between z and e.
  const double s = e.z >= 0 ? 1.0 + e.z : (e.x * e.x + e.y * e.y) / (1.0 - e.z);
  const double n = std::sqrt(s * s + e.x * e.x + e.y * e.y);
  if (n == 0.0) return {0.0, 1.0, 0.0, 0.0};  // e = -z: half a turn about x
  return {s / n, -e.y / n, e.x / n, 0.0};
}

Vec3 axis_from_quaternion(const Quaternion &q_in) {
  const Quaternion q = normalised(q_in);
  const double s = q[0], x = q[1], y = q[2], z = q[3];
  const Vec3 e{2.0 * (x * z + s * y), 2.0 * (y * z - s * x), 1.0 - 2.0 * (x * x + y * y)};
  return (1.0 / norm(e)) * e;
}

Quaternion angmom_from_angular_velocity(const Quaternion &q, const Vec3 &w, double inertia_perp) {
  // 2 q (0, S_body) = 2 (0, S_space) q, and S_space = I_perp w for w perpendicular to the axis.
  const Quaternion p = multiply(pure(inertia_perp * w), q);
  return {2.0 * p[0], 2.0 * p[1], 2.0 * p[2], 2.0 * p[3]};
}

Vec3 angular_velocity_from_angmom(const Quaternion &q_in, const Quaternion &p,
                                  const Vec3 &inertia) {
  const Quaternion q = normalised(q_in);
  const Vec3 s = 0.5 * vector_part(multiply(conjugate(q), p));  // body frame
  const Vec3 w_body{inertia.x > 0 ? s.x / inertia.x : 0.0, inertia.y > 0 ? s.y / inertia.y : 0.0,
                    inertia.z > 0 ? s.z / inertia.z : 0.0};
  return vector_part(multiply(multiply(q, pure(w_body)), conjugate(q)));
}

Wrapped wrap_for_hoomd(double u, double side) {
  double image = std::floor(u / side + 0.5);
  double p = u - image * side;
  if (p >= 0.5 * side) p -= side, image += 1;
  if (p < -0.5 * side) p += side, image -= 1;
  float f = static_cast<float>(p);
  // HOOMD checks -L/2 <= x < L/2 in float, with its float box: rounding up to L/2 is outside.
  if (f >= 0.5f * static_cast<float>(side)) {
    p -= side, image += 1;
    f = static_cast<float>(p);
  }
  if (!(std::fabs(image) < static_cast<double>(std::numeric_limits<std::int32_t>::max())))
    throw std::runtime_error(fmt::format("coordinate {} is {} boxes away", u, image));
  return {f, static_cast<int>(image)};
}

std::string hoomd_type_name(const Shape &shape) { return shape.is_sphere() ? "sphere" : "rod"; }

std::string hoomd_shape_json(const Shape &shape) {
  if (shape.is_sphere())
    return fmt::format("{{\"type\": \"Sphere\", \"diameter\": {}}}", shape.diameter);
  return fmt::format(
      "{{\"type\": \"ConvexPolyhedron\", \"rounding_radius\": {}, \"vertices\": "
      "[[0, 0, {}], [0, 0, {}]]}}",
      shape.radius(), -shape.half_length(), shape.half_length());
}

namespace {

// A string chunk: one NUL-padded row per string, int8 as the schema has it.
std::vector<std::int8_t> string_rows(const std::string &s) {
  std::vector<std::int8_t> row(s.begin(), s.end());
  row.push_back(0);
  return row;
}

void append_constant_chunks(gsd::Writer &w, std::size_t n, const Shape &shape) {
  w.write_chunk("configuration/dimensions", std::vector<std::uint8_t>{3}, 1);
  const std::vector<std::int8_t> type = string_rows(hoomd_type_name(shape));
  w.write_chunk("particles/types", type, static_cast<std::uint32_t>(type.size()));
  const std::vector<std::int8_t> json = string_rows(hoomd_shape_json(shape));
  w.write_chunk("particles/type_shapes", json, static_cast<std::uint32_t>(json.size()));
  w.write_chunk("particles/typeid", std::vector<std::uint32_t>(n, 0), 1);
  w.write_chunk("particles/mass", std::vector<float>(n, static_cast<float>(shape.mass)), 1);
  w.write_chunk("particles/diameter", std::vector<float>(n, static_cast<float>(shape.diameter)), 1);
  const float inertia = shape.is_sphere() ? 0.0f : static_cast<float>(shape.inertia_perp());
  std::vector<float> moments(3 * n, inertia);
  for (std::size_t i = 0; i < n; ++i) moments[3 * i + 2] = 0.0f;  // none about the axis
  w.write_chunk("particles/moment_inertia", moments, 3);
}

}  // namespace

void append_hoomd_frame(gsd::Writer &w, const SnapshotFrame &f, const Shape &shape, bool first) {
  const Particles &p = f.bodies;
  const std::size_t n = p.size();
  const Vec3 &l = f.box.length;
  if (first) append_constant_chunks(w, n, shape);
  w.write_chunk("configuration/step",
                std::vector<std::uint64_t>{static_cast<std::uint64_t>(f.step)}, 1);
  const std::vector<float> box{
      static_cast<float>(l.x), static_cast<float>(l.y), static_cast<float>(l.z), 0.0f, 0.0f, 0.0f};
  w.write_chunk("configuration/box", box, 1);
  w.write_chunk("particles/N", std::vector<std::uint32_t>{static_cast<std::uint32_t>(n)}, 1);
  std::vector<float> position(3 * n), orientation(4 * n), velocity(3 * n), angmom(4 * n);
  std::vector<std::int32_t> image(3 * n);
  const double inertia = shape.is_sphere() ? 0.0 : shape.inertia_perp();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 u = p.position(i), v = p.velocity(i);
    const double side[3] = {l.x, l.y, l.z}, coordinate[3] = {u.x, u.y, u.z};
    for (std::size_t a = 0; a < 3; ++a) {
      const Wrapped c = wrap_for_hoomd(coordinate[a], side[a]);
      position[3 * i + a] = c.position;
      image[3 * i + a] = c.image;
    }
    velocity[3 * i] = static_cast<float>(v.x);
    velocity[3 * i + 1] = static_cast<float>(v.y);
    velocity[3 * i + 2] = static_cast<float>(v.z);
    const Quaternion q = quaternion_from_axis(p.axis(i));
    const Quaternion m = angmom_from_angular_velocity(q, p.angular_velocity(i), inertia);
    for (std::size_t c = 0; c < 4; ++c) {
      orientation[4 * i + c] = static_cast<float>(q[c]);
      angmom[4 * i + c] = static_cast<float>(m[c]);
    }
  }
  w.write_chunk("particles/position", position, 3);
  w.write_chunk("particles/orientation", orientation, 4);
  w.write_chunk("particles/velocity", velocity, 3);
  w.write_chunk("particles/angmom", angmom, 4);
  w.write_chunk("particles/image", image, 3);
  w.end_frame();
}

}  // namespace hardrod
