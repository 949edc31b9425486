// `hardrod export TRAJECTORY.h5 [--frame K] [--format xyz|gsd|pov] [--out FILE]`: an H5MD
// trajectory's frames (every frame, or frame K) as extended XYZ (ASE, OVITO) or as GSD in
// HOOMD's schema (HOOMD-blue, OVITO, freud, MDAnalysis; runtime/hoomd_gsd.hpp), or one frame
// (K, default the last) as a POV-Ray scene (runtime/export_pov.hpp).
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
#include "runtime/export_pov.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

enum class ExportFormat { kXyz, kGsd, kPov };

// `format` "xyz", "gsd" or "pov"; empty: from `out`'s extension (.gsd: GSD, .pov: POV-Ray,
// anything else or none: XYZ, except an HDF5 name, .h5, .hdf5 or .h5md, which is refused:
// XYZ goes into such a file only with --format xyz). Throws std::invalid_argument naming
// --format and the value, or the extension and --format.
ExportFormat choose_export_format(const std::string &format, const std::string &out);

// Refuses (std::invalid_argument naming --out and the path) an `out` that export must not
// replace: anything there but a regular file (a directory, a device such as /dev/null, a
// FIFO, a symbolic link: export does not write through links), or `out`.tmp being one; the
// input file itself, or one of the run's own files in the input's directory (by name, or
// the same file under another name: compared by device and inode). Changes nothing.
void check_export_target(const std::string &input, const std::string &out);

// The rod shape an H5MD file was written with (/parameters aspect_ratio and diameter).
Shape read_h5md_shape(const std::string &path);
// read_h5md_frame, plus the frame's velocities and angular velocities (zero where the file
// has none). Throws std::runtime_error naming the file, dataset and frame.
SnapshotFrame read_h5md_frame_with_velocities(const std::string &path, long long frame);

// One frame as an extended XYZ block (format above).
std::string extended_xyz(const SnapshotFrame &frame, const Shape &shape);

// Writes the export; `out` empty: standard output (XYZ and POV only). A file is written to
// `out`.tmp and renamed when complete, so an error leaves nothing half-written; an `out`
// that check_export_target refuses is refused before anything is read. POV: one frame,
// `frame` or the last; `slab` only there.
void export_trajectory(const std::string &h5md, std::optional<long long> frame,
                       const std::string &out, ExportFormat format,
                       const std::optional<PovSlab> &slab = std::nullopt);

}  // namespace hardrod
