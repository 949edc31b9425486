// Trajectory snapshots in H5MD 1.1 (HDF5), readable by h5py and MDAnalysis:
//   /h5md (version 1.1, author, creator)
//   /particles/all/box (dimension 3, boundary periodic, edges [3])
//   /particles/all/{position, velocity, axis, angular_velocity}/{step, time, value[T][N][3]}
//   /particles/all/id/value[N]  (bodies in id order in every frame)
//   /parameters (attributes: aspect_ratio, diameter, n)
// Frames are appended to one file (extensible, chunked datasets). Written by rank 0 from the
// bodies gathered in id order.
#pragma once

#include <string>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"
#include "runtime/scene.hpp"

namespace hardrod {

// One frame of an H5MD file (hardrod's trajectory.h5, or any H5MD file with
// /particles/all/position, axis and box/edges): positions and axes in id order.
struct SnapshotFrame {
  Particles bodies;  // ids 0..n-1; velocities zero
  long long step = 0;
  long long frame = 0;  // the frame read (counted from 0)
  long long frames = 0;
  Box box;
};

// `frame` < 0 counts from the end (-1: the last). Checks layout, shapes, frame range, finite
// values, unit axes, ids; throws std::runtime_error naming the file, the dataset and the
// problem.
SnapshotFrame read_h5md_frame(const std::string &path, long long frame);

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

 private:
  void cut_back(long long n, long long keep_frames);
  long long file_ = -1;  // hid_t, kept opaque so only snapshot.cpp includes hdf5.h
  long long n_ = 0;
  long long frames_ = 0;
  std::string path_;
};

}  // namespace hardrod
