// Trajectory snapshots in H5MD 1.1 (HDF5), readable by h5py and MDAnalysis:
//   /h5md (version 1.1, author, creator name and version)
//   /particles/all/{position, velocity, axis, angular_velocity}/{step, time, value[T][N][3]}
//     positions unwrapped (continuous over the run, see docs/units.md), bodies in id order
//   /particles/all/box (dimension 3, boundary periodic) with edges/{step, time, value[T][3][3]}
//     (a diagonal matrix per frame: the form MDAnalysis reads; step and time are position's)
//   /particles/all/id/value[N]
//   /observables/state_checksum/{step, time, value[T]}: each frame's state checksum
//   /particles/wrapped/{position, image}: positions folded into [0, l) and the integer image
//     counts, position + image * edges = /particles/all/position to round-off
//   /parameters (attributes: aspect_ratio, diameter, n, shape, and the provenance: version,
//     git_commit, command_line, started_at, host)
// Units are hardrod's reduced ones (D, m, kT, tau), named in /h5md/modules/units and on each
// value and time dataset as a `reduced_unit` attribute ("D", "tau", "D tau-1", "tau-1"); no
// H5MD `unit` attribute, which MDAnalysis rejects unless it is a unit it knows.
// Frames are appended to one file (extensible, chunked datasets). Written by rank 0 from the
// bodies gathered in id order. Files written before the box was time-dependent (edges[3], no
// /particles/wrapped) are still read, and a resume goes on writing them in their own layout.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"
#include "runtime/scene.hpp"

namespace hardrod {

// One frame of an H5MD file (hardrod's trajectory.h5, or any H5MD file with
// /particles/all/position, axis and box/edges, fixed or time-dependent): positions and axes
// in id order.
struct SnapshotFrame {
  Particles bodies;  // ids 0..n-1; velocities zero
  long long step = 0;
  long long frame = 0;  // the frame read (counted from 0)
  long long frames = 0;
  Box box;
};

// Before any other HDF5 call: HDF5 registers no exit handler. Its handler closes what is still
// open, and a file whose close already failed (a full disk) crashes it; the program closes its
// files itself.
void keep_hdf5_out_of_exit();

// `frame` < 0 counts from the end (-1: the last). Checks layout, shapes, frame range, finite
// values, unit axes, ids; throws std::runtime_error naming the file, the dataset and the
// problem.
SnapshotFrame read_h5md_frame(const std::string &path, long long frame);

// Frame `frame`'s state checksum (/observables/state_checksum: body_hash of the frame as
// written), or nothing for a file written before frames carried one.
std::optional<std::uint64_t> read_frame_checksum(const std::string &path, long long frame);

class TrajectoryWriter {
 public:
  // Creates (truncates) the file. Throws std::runtime_error naming the path on failure.
  TrajectoryWriter(const std::string &path, const Scene &scene);
  // Reopens an existing file (a resumed run) and cuts it back to its first `keep_frames`
  // frames. Throws std::runtime_error if it cannot be opened or does not fit the scene.
  TrajectoryWriter(const std::string &path, const Scene &scene, long long keep_frames);
  ~TrajectoryWriter();
  TrajectoryWriter(const TrajectoryWriter &) = delete;
  TrajectoryWriter &operator=(const TrajectoryWriter &) = delete;

  // `bodies` in id order, all n of them.
  void append(const Particles &bodies, long long step, double time);
  long long frames() const { return frames_; }
  // The data of one frame in bytes (its chunks' overhead aside).
  std::uintmax_t frame_bytes() const {
    const auto n = static_cast<std::uintmax_t>(n_);
    return n * 4 * 3 * sizeof(double) + (wrapped_ ? n * 3 * (sizeof(double) + sizeof(int)) : 0) +
           9 * sizeof(double) + 16 * sizeof(double);
  }

 private:
  void cut_back(long long n, long long keep_frames);
  void close_file(const std::string &what);  // throws naming `what` where the close failed
  // hid_t, kept opaque so only snapshot.cpp includes hdf5.h. The file is open only while it
  // is made, cut back or given a frame: between frames readers may open it, and a disk that
  // fills with other files cannot catch it with data still to write.
  long long file_ = -1;
  long long n_ = 0;
  long long frames_ = 0;
  std::array<double, 3> edges_{};  // the box, for the time-dependent box/edges
  bool box_series_ = false;        // box/edges is time-dependent (false: an older file)
  bool wrapped_ = false;           // /particles/wrapped is present (false: an older file)
  bool checksums_ = false;         // /observables/state_checksum is present (idem)
  std::string path_;
};

}  // namespace hardrod
