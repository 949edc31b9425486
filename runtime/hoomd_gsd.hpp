// hardrod's bodies in HOOMD-blue's GSD schema ("hoomd" 1.4), the format HOOMD-blue, OVITO,
// freud and MDAnalysis read: `hardrod export --format gsd` writes every frame of an H5MD
// trajectory this way, and `init.configuration = "file"` with a .gsd file starts a run from
// one frame.
//
// Conventions (HOOMD's; docs: hoomd-blue "Anisotropic particles", gsd "HOOMD schema"):
// - the box is [Lx, Ly, Lz, xy, xz, yz] (tilts 0 here), centred on the origin: a position
//   lies in [-L/2, L/2) per axis, and `image` counts whole boxes, so position + image * L is
//   hardrod's unwrapped centre (no shift of origin: the periodic system is the same).
// - the body axis of the shape is +z: `orientation` is the unit quaternion q = (s, x, y, z),
//   scalar first, with q (0, z) q* = the rod's axis e.
// - `angmom` is the angular momentum quaternion P = 2 q (0, S) (Kamberaj 2005), S the angular
//   momentum in the body frame, so S = 1/2 Im(q* P); for a rod S = I_perp w in body
//   coordinates, and `moment_inertia` is (I_perp, I_perp, 0): HOOMD integrates no rotation
//   about the axis, as hardrod's rotor constraint.
// - the shape: {"type": "ConvexPolyhedron", "rounding_radius": D/2, "vertices":
//   [[0,0,-L/2],[0,0,L/2]]}, a spherocylinder along +z; {"type": "Sphere", "diameter": D}
//   for L = 0. One particle type, "rod" (or "sphere").
// GSD stores these as 32-bit floats (the schema's type, which HOOMD requires): a position
// keeps ~7 digits (about 1e-6 D in a box of 30 D), an axis ~1e-7.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"
#include "kernels/vec3.hpp"
#include "runtime/gsd_writer.hpp"
#include "runtime/scene.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

using Quaternion = std::array<double, 4>;  // (s, x, y, z)

// The unit quaternion that turns +z onto the unit vector e (the shorter turn; a half turn
// about x for e = -z). Stable near e = -z: 1 + e_z is computed as (e_x^2 + e_y^2)/(1 - e_z).
Quaternion quaternion_from_axis(const Vec3 &e);
// q (0, z) q*, with q normalised first.
Vec3 axis_from_quaternion(const Quaternion &q);
// HOOMD's angular momentum quaternion of a rod turning at w (w perpendicular to the axis).
Quaternion angmom_from_angular_velocity(const Quaternion &q, const Vec3 &w, double inertia_perp);
// The angular velocity of HOOMD's (q, P) with principal moments `inertia` (body x, y, z): a
// moment of 0 means that axis does not turn. q normalised first.
Vec3 angular_velocity_from_angmom(const Quaternion &q, const Quaternion &p, const Vec3 &inertia);

// Splits an unwrapped coordinate u into HOOMD's wrapped one (as float, in [-L/2, L/2) after
// rounding to float) and the image count: u ~ position + image * side.
struct Wrapped {
  float position;
  int image;
};
Wrapped wrap_for_hoomd(double u, double side);

// The shape's type name and its type_shapes JSON.
std::string hoomd_type_name(const Shape &shape);
std::string hoomd_shape_json(const Shape &shape);

// One frame of a GSD file: positions as in the file (wrapped) with their image counts, axes,
// and (if the frame has any non-zero velocity or angular momentum) velocities and angular
// velocities perpendicular to the axes (spheres: none).
struct GsdFrame {
  Particles bodies;                           // ids 0..n-1
  std::vector<std::array<int, 3>> image;      // position + image * L is the unwrapped centre
  Box box;                                    // the file's (32-bit) box
  long long step = 0, frame = 0, frames = 0;  // the frame read (from 0), of how many
  bool has_velocities = false;
};
// `frame` < 0 counts from the end. A chunk absent from the frame is taken from frame 0, then
// from the schema's default (HOOMD's rule); angular momenta are turned into angular
// velocities with the file's moments of inertia where it has them, else the shape's.
// Checks: the hoomd schema, 3 dimensions, an orthorhombic box, N, chunk shapes, finite
// values, non-zero quaternions; throws std::runtime_error naming the file, frame and chunk.
GsdFrame read_gsd_frame(const std::string &path, long long frame, const Shape &shape);

// A file ending in .gsd (init.file: a GSD start, runtime/start.hpp).
bool is_gsd_path(const std::string &path);

// Appends `frame` (unwrapped centres, axes, velocities) as the writer's next GSD frame. The
// first frame also carries what does not change: types, shapes, mass, diameter, moments of
// inertia (HOOMD readers take them from frame 0).
void append_hoomd_frame(gsd::Writer &writer, const SnapshotFrame &frame, const Shape &shape,
                        bool first);

}  // namespace hardrod
