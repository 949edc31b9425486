// `hardrod export TRAJECTORY.h5 [--frame K] [--format xyz|gsd] [--out FILE]`: an H5MD
// trajectory's frames (every frame, or frame K) as extended XYZ (ASE, OVITO) or as GSD in
// HOOMD's schema (HOOMD-blue, OVITO, freud, MDAnalysis; runtime/hoomd_gsd.hpp).
//
// Extended XYZ, one block per frame: "n", then the comment line
//   Lattice="Lx 0 0 0 Ly 0 0 0 Lz" Origin="0 0 0" pbc="T T T"
//   Properties=species:S:1:pos:R:3:orientation:R:4:aspherical_shape:R:3:id:I:1 step=S frame=F
// and a row per body in id order: species "X" (ASE's dummy atom: a rod is no element, and
// ASE refuses unknown symbols), the centre folded into [0, L), the orientation quaternion in
// OVITO's order (x, y, z, w: scalar last) turning +z onto the axis, the OVITO spherocylinder
// size (radius D/2, D/2, cylinder length L along the local z) and the id.
#pragma once

#include <optional>
#include <string>

#include "kernels/shape.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

enum class ExportFormat { kXyz, kGsd };

// `format` "xyz" or "gsd"; empty: from `out`'s extension (.gsd: GSD, anything else or none:
// XYZ). Throws std::invalid_argument naming --format and the value.
ExportFormat choose_export_format(const std::string &format, const std::string &out);

// The rod shape an H5MD file was written with (/parameters aspect_ratio and diameter).
Shape read_h5md_shape(const std::string &path);
// read_h5md_frame, plus the frame's velocities and angular velocities (zero where the file
// has none). Throws std::runtime_error naming the file, dataset and frame.
SnapshotFrame read_h5md_frame_with_velocities(const std::string &path, long long frame);

// One frame as an extended XYZ block (format above).
std::string extended_xyz(const SnapshotFrame &frame, const Shape &shape);

// Writes the export; `out` empty: standard output (XYZ only). A file is written to
// `out`.tmp and renamed when complete, so an error leaves nothing half-written.
void export_trajectory(const std::string &h5md, std::optional<long long> frame,
                       const std::string &out, ExportFormat format);

}  // namespace hardrod
