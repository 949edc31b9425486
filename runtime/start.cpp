// The start (see the header): the lattice and the isotropic compression from the kernels, the
// frames of files through their readers (runtime/snapshot.hpp, runtime/hoomd_gsd.hpp), and the
// checks every frame from a file passes.
#include "runtime/start.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <stdexcept>
#include <string>

#include "kernels/initial_state.hpp"
#include "kernels/isotropic_start.hpp"
#include "kernels/neighbor_list.hpp"
#include "runtime/checkpoint.hpp"
#include "runtime/export.hpp"
#include "runtime/hoomd_gsd.hpp"
#include "runtime/signals.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

namespace {

// A frame of a start file, as both readers give it.
struct StartFrame {
  Particles bodies;
  Box box;
  long long frame = 0;
  bool has_velocities = false;
  // The file holds 32-bit floats (GSD): its box is the scene's rounded to float.
  bool single_precision = false;
};

bool any_motion(const Particles &p) {
  for (std::size_t i = 0; i < p.size(); ++i)
    if (p.vx[i] != 0 || p.vy[i] != 0 || p.vz[i] != 0 || p.wx[i] != 0 || p.wy[i] != 0 ||
        p.wz[i] != 0)
      return true;
  return false;
}

// The frame with its velocities (none stored, or all zero: drawn as for the other starts),
// checked against the state checksum it was written with, as export checks it.
StartFrame read_h5md_start(const Scene &scene) {
  SnapshotFrame f = read_h5md_frame_with_velocities(scene.init_file, scene.init_frame);
  const std::optional<std::uint64_t> stored = read_frame_checksum(scene.init_file, f.frame);
  const std::uint64_t now = body_hash(f.bodies);
  if (stored && now != *stored)
    throw std::runtime_error(
        fmt::format("frame {} is damaged: its data hash to {:016x}, it was written as {:016x} "
                    "(/observables/state_checksum; a frame edited on purpose starts once that "
                    "dataset is removed)",
                    f.frame, now, *stored));
  const bool moving = any_motion(f.bodies);
  return {std::move(f.bodies), f.box, f.frame, moving, false};
}

// Unwrapped with the scene's box in double (the file's is rounded to float).
StartFrame read_gsd_start(const Scene &scene) {
  GsdFrame f = read_gsd_frame(scene.init_file, scene.init_frame, scene.shape);
  Particles &p = f.bodies;
  const Vec3 &side = scene.box.length;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::array<int, 3> &m = f.image[i];
    p.x[i] += m[0] * side.x;
    p.y[i] += m[1] * side.y;
    p.z[i] += m[2] * side.z;
  }
  return {std::move(f.bodies), f.box, f.frame, f.has_velocities, true};
}

bool same_box(const Box &file, const Box &scene, bool single_precision) {
  const Vec3 &a = file.length, &b = scene.length;
  if (single_precision)
    return a.x == static_cast<float>(b.x) && a.y == static_cast<float>(b.y) &&
           a.z == static_cast<float>(b.z);
  for (double r : {a.x / b.x, a.y / b.y, a.z / b.z})
    if (!(std::fabs(r - 1.0) <= 1e-12)) return false;
  return true;
}

// A frame may hold overlapping bodies (a damaged or hand-made frame, another shape): said here,
// naming the deepest pair, rather than at the first step as a dt problem.
void check_overlaps(const Scene &scene, const Particles &all, const std::string &key,
                    long long frame) {
  Particles copy = all;  // the list build reorders the bodies
  NeighborList list;
  list.skin = 1e-6;
  build_neighbor_list(list, copy, copy.size(), scene.box, scene.shape);
  double deepest = 0.0;
  const ListedPair *worst = nullptr;
  for (const ListedPair &pair : list.pairs)
    if (-pair.recheck_at > deepest) deepest = -pair.recheck_at, worst = &pair;
  if (deepest <= scene.max_overlap) return;
  throw SceneError({fmt::format(
      "{}: frame {}: the start configuration overlaps: bodies {} and {} by {:.4g} D (more than "
      "run.max_overlap = {:g} D); not a hard-body state for L/D = {:g} (another shape, or a "
      "damaged file?)",
      key, frame, copy.id[worst->first], copy.id[worst->second], deepest, scene.max_overlap,
      scene.shape.length / scene.shape.diameter)});
}

// A frame of init.file, checked against the scene.
Particles start_from_file(const Scene &scene) {
  const std::string key = fmt::format("init.file = \"{}\"", scene.init_file);
  StartFrame f;
  try {
    f = is_gsd_path(scene.init_file) ? read_gsd_start(scene) : read_h5md_start(scene);
  } catch (const std::runtime_error &e) {
    throw SceneError({fmt::format("{}: {}", key, e.what())});
  }
  if (static_cast<long long>(f.bodies.size()) != scene.n)
    throw SceneError({fmt::format("{}: frame {} holds {} bodies, system.n = {}", key, f.frame,
                                  f.bodies.size(), scene.n)});
  if (!same_box(f.box, scene.box, f.single_precision)) {
    const Vec3 &a = f.box.length, &b = scene.box.length;
    throw SceneError({fmt::format(
        "{}: frame {}: box {} x {} x {}, the scene's is {} x {} x {} (system.box or the density)",
        key, f.frame, a.x, a.y, a.z, b.x, b.y, b.z)});
  }
  check_overlaps(scene, f.bodies, key, f.frame);
  if (!f.has_velocities) assign_velocities(f.bodies, scene.shape, scene.seed, scene.temperature);
  return std::move(f.bodies);
}

}  // namespace

Particles initial_bodies(const Scene &scene, bool stoppable, bool report) {
  if (scene.configuration == Configuration::kFile) return start_from_file(scene);
  Particles all;
  if (scene.configuration == Configuration::kIsotropic) {
    try {
      CompressionOptions options;
      options.max_sweeps = scene.isotropic_sweeps;
      if (stoppable) options.stop = [] { return stop_signal() != 0; };
      if (report)
        options.progress = [&scene](long long sweeps, double scale) {
          fmt::print("isotropic start: {} of at most {} sweeps, box side {:.4f} x the target's\n",
                     sweeps, scene.isotropic_sweeps, scale);
          std::fflush(stdout);
        };
      all = make_isotropic(scene.n, scene.shape, scene.box, scene.seed, options);
    } catch (const CompressionStopped &) {
      throw;
    } catch (const std::exception &e) {
      throw SceneError({fmt::format(
          "init.configuration = \"isotropic\": {} (init.isotropic_sweeps = {}); dense nematic "
          "states are reached from the lattice instead (init.configuration = \"lattice\", which "
          "also melts into the isotropic phase below rho* ~ 0.4)",
          e.what(), scene.isotropic_sweeps)});
    }
  } else {
    place_on_lattice(all, scene.box, scene.lattice, scene.axis);
  }
  assign_velocities(all, scene.shape, scene.seed, scene.temperature);
  return all;
}

}  // namespace hardrod
