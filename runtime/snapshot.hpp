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

class TrajectoryWriter {
 public:
  // Creates (truncates) the file. Throws std::runtime_error naming the path on failure.
  TrajectoryWriter(const std::string &path, const Scene &scene);
  ~TrajectoryWriter();
  TrajectoryWriter(const TrajectoryWriter &) = delete;
  TrajectoryWriter &operator=(const TrajectoryWriter &) = delete;

  // `bodies` in id order, all n of them.
  void append(const Particles &bodies, long long step, double time);
  long long frames() const { return frames_; }

 private:
  long long file_ = -1;  // hid_t, kept opaque so only snapshot.cpp includes hdf5.h
  long long n_ = 0;
  long long frames_ = 0;
  std::string path_;
};

}  // namespace hardrod
