// A frame of a GSD file in HOOMD's schema read as hardrod's bodies (runtime/hoomd_gsd.hpp), with
// the file's own checks; a start's checks against the scene are runtime/start.cpp's.
#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <stdexcept>

#include "runtime/gsd_reader.hpp"
#include "runtime/hoomd_gsd.hpp"

namespace hardrod {

namespace {

// One frame's chunks, with HOOMD's fallback to frame 0 and the shape checked.
class FrameChunks {
 public:
  FrameChunks(const gsd::Reader &r, std::uint64_t frame) : r_(r), frame_(frame) {}
  // The chunk's values (rows x columns), or nullopt if neither this frame nor frame 0 has it.
  std::optional<std::vector<double>> get(const std::string &name, std::uint64_t rows,
                                         std::uint32_t columns) const {
    const gsd::IndexEntry *e = r_.find(frame_, name);
    if (e == nullptr) {
      e = r_.find(0, name);  // frame 0's, if it has as many rows (gsd.hoomd's rule)
      if (e == nullptr || e->n != rows) return std::nullopt;
    }
    if (e->n != rows || e->m != columns)
      throw std::runtime_error(fmt::format("{}: frame {}: {} is {} x {}, expected {} x {}",
                                           r_.path(), frame_, name, e->n, e->m, rows, columns));
    std::vector<double> v = r_.read<double>(*e);
    for (std::size_t k = 0; k < v.size(); ++k)
      if (!std::isfinite(v[k]))
        throw std::runtime_error(fmt::format("{}: frame {}: {} row {}: not finite", r_.path(),
                                             frame_, name, k / columns));
    return v;
  }
  std::vector<double> required(const std::string &name, std::uint64_t rows,
                               std::uint32_t columns) const {
    auto v = get(name, rows, columns);
    if (!v) throw std::runtime_error(fmt::format("{}: frame {}: no {}", r_.path(), frame_, name));
    return *v;
  }

 private:
  const gsd::Reader &r_;
  std::uint64_t frame_;
};

Box read_box(const FrameChunks &c, const std::string &path, long long frame) {
  const std::vector<double> b = c.required("configuration/box", 6, 1);
  if (b[3] != 0 || b[4] != 0 || b[5] != 0)
    throw std::runtime_error(fmt::format(
        "{}: frame {}: configuration/box has tilts xy = {}, xz = {}, yz = {}: hardrod's box is "
        "orthorhombic",
        path, frame, b[3], b[4], b[5]));
  for (int a = 0; a < 3; ++a)
    if (!(b[a] > 0))
      throw std::runtime_error(
          fmt::format("{}: frame {}: configuration/box edge {}: must be > 0", path, frame, b[a]));
  return Box{{b[0], b[1], b[2]}};
}

// Axes and angular velocities from orientation, angmom and moment_inertia.
void read_rotations(const FrameChunks &c, GsdFrame &out, const Shape &shape,
                    const std::string &path) {
  Particles &p = out.bodies;
  const std::size_t n = p.size();
  const auto q = c.get("particles/orientation", n, 4);
  const auto m = c.get("particles/angmom", n, 4);
  const auto inertia = c.get("particles/moment_inertia", n, 3);
  const double own = shape.is_sphere() ? 0.0 : shape.inertia_perp();
  for (std::size_t i = 0; i < n; ++i) {
    const Quaternion qi =
        q ? Quaternion{(*q)[4 * i], (*q)[4 * i + 1], (*q)[4 * i + 2], (*q)[4 * i + 3]}
          : Quaternion{1, 0, 0, 0};
    if (qi[0] * qi[0] + qi[1] * qi[1] + qi[2] * qi[2] + qi[3] * qi[3] < 1e-12)
      throw std::runtime_error(
          fmt::format("{}: frame {}: particles/orientation of particle {} is zero, not a rotation",
                      path, out.frame, i));
    const Vec3 e = axis_from_quaternion(qi);
    p.set_axis(i, e);
    if (!m || shape.is_sphere()) continue;
    const Quaternion mi{(*m)[4 * i], (*m)[4 * i + 1], (*m)[4 * i + 2], (*m)[4 * i + 3]};
    Vec3 moments{own, own, 0.0};
    if (inertia && (*inertia)[3 * i] > 0 && (*inertia)[3 * i + 1] > 0)
      moments = {(*inertia)[3 * i], (*inertia)[3 * i + 1], (*inertia)[3 * i + 2]};
    Vec3 w = angular_velocity_from_angmom(qi, mi, moments);
    w = w - dot(w, e) * e;  // hardrod's rods do not spin about their axis
    p.set_angular_velocity(i, w);
    if (norm2(w) > 0) out.has_velocities = true;
  }
}

}  // namespace

GsdFrame read_gsd_frame(const std::string &path, long long frame, const Shape &shape) {
  const gsd::Reader r(path);
  if (r.schema() != "hoomd" || (r.schema_version() >> 16) != 1)
    throw std::runtime_error(fmt::format("{}: schema '{}' version {}.{}: not HOOMD's (hoomd 1.x)",
                                         path, r.schema(), r.schema_version() >> 16,
                                         r.schema_version() & 0xffff));
  GsdFrame out;
  out.frames = static_cast<long long>(r.frames());
  out.frame = frame < 0 ? out.frames + frame : frame;
  if (out.frame < 0 || out.frame >= out.frames)
    throw std::runtime_error(
        fmt::format("{}: frame {} requested, the file has {} frame(s)", path, frame, out.frames));
  const FrameChunks c(r, static_cast<std::uint64_t>(out.frame));
  if (const auto d = c.get("configuration/dimensions", 1, 1); d && (*d)[0] != 3)
    throw std::runtime_error(fmt::format("{}: frame {}: configuration/dimensions = {}, not 3", path,
                                         out.frame, (*d)[0]));
  if (const auto s = c.get("configuration/step", 1, 1)) out.step = static_cast<long long>((*s)[0]);
  out.box = read_box(c, path, out.frame);
  const auto count = c.get("particles/N", 1, 1);
  if (!count || (*count)[0] < 1)
    throw std::runtime_error(
        fmt::format("{}: frame {}: no particles (particles/N)", path, out.frame));
  const auto n = static_cast<std::size_t>((*count)[0]);
  const std::vector<double> x = c.required("particles/position", n, 3);
  const auto image = c.get("particles/image", n, 3);
  const auto v = c.get("particles/velocity", n, 3);
  Particles &p = out.bodies;
  p.resize(n);
  out.image.assign(n, {0, 0, 0});
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(i);
    p.set_position(i, {x[3 * i], x[3 * i + 1], x[3 * i + 2]});
    if (image)
      for (std::size_t a = 0; a < 3; ++a) out.image[i][a] = static_cast<int>((*image)[3 * i + a]);
    if (v) p.set_velocity(i, {(*v)[3 * i], (*v)[3 * i + 1], (*v)[3 * i + 2]});
    if (v && norm2(p.velocity(i)) > 0) out.has_velocities = true;
  }
  read_rotations(c, out, shape, path);
  return out;
}

bool is_gsd_path(const std::string &path) {
  return std::filesystem::path(path).extension() == ".gsd";
}

}  // namespace hardrod
