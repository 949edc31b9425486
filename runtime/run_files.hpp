// The files of a run directory that rank 0 writes as the run goes: scene.toml (the scene as
// run), timeseries.csv (one row per sample, flushed at once), trajectory.h5 (H5MD frames),
// angular.json, and the atomic write that summary.json uses too. A fresh run refuses a
// directory that already holds a run; a resumed one cuts the files back to what its
// checkpoint recorded. What goes into summary.json is decided in run_report.hpp, the
// checkpoint file itself in checkpoint.hpp.
#pragma once

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "kernels/order_tensor.hpp"
#include "runtime/comm.hpp"
#include "runtime/run_lock.hpp"
#include "runtime/scene.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

struct RunState;

// One row of timeseries.csv.
struct Sample {
  long long step = 0;
  bool production = false;
  double order_parameter = 0.0;
  double pressure_star = 0.0;  // of the interval that ends here
  double temperature = 0.0;
  double kinetic_energy = 0.0;
  long long collisions = 0;  // cumulative
  double max_depth = 0.0;    // of the interval
};

// Refuses to overwrite an earlier run unless `force`: nothing already written is lost.
// Creates the directory. Throws SceneError.
void prepare_output_dir(const std::filesystem::path &dir, bool force);

// Whether `a` and `b` are one file (device and inode, after resolving links); false where
// either is missing.
bool same_file(const std::filesystem::path &a, const std::filesystem::path &b);

// Whether `name` (a file name, no folder) is one of the files that hardrod, its analysis and
// its scripts write into a run directory: the outputs, the checkpoints, their temporary files
// and the trajectories kept aside by a resume. The lock file is not one.
bool is_run_file_name(const std::string &name);

// The earlier run's files in `dir` (is_run_file_name) removed, so that a forced run leaves
// only its own; anything else there stays. Returns their names, sorted. Throws SceneError
// naming the first file that could not be removed.
std::vector<std::string> remove_run_files(const std::filesystem::path &dir);

// Writes `text` to `path` through a temporary file and a rename. Throws SceneError.
void write_atomically(const std::filesystem::path &path, const std::string &text);

// timeseries.csv.
class TimeSeries {
 public:
  static constexpr const char *kHeader =
      "step,time,phase,order_parameter,pressure_star,pressure_star_running,"
      "kinetic_energy,temperature,collisions,max_overlap\n";
  // A new file with the header (keep_bytes < 0), or (resume) the existing one cut back to
  // `keep_bytes`. Throws SceneError.
  TimeSeries(const std::filesystem::path &path, long long keep_bytes);
  // Throws std::runtime_error naming the file and the reason where the row did not reach it.
  void write(const Sample &s, double dt, double running);
  // The bytes of whole rows on disk (what a checkpoint records; a failed row is not counted).
  long long bytes() const { return bytes_; }

 private:
  std::filesystem::path path_;
  std::ofstream out_;
  long long bytes_ = 0;
};

// The trajectory of a resumed run: the existing file cut back to the checkpoint's frames. A
// file that cannot be reopened (a job killed while writing it) is kept under another name
// and a new one is started, so nothing already written is lost.
std::unique_ptr<TrajectoryWriter> reopen_trajectory(const std::filesystem::path &path,
                                                    const Scene &scene, long long frames,
                                                    long long step);

// The open output of a run; all empty on ranks other than 0.
struct RunFiles {
  std::unique_ptr<RunLock> lock;  // the directory is this process's while the files are open
  std::unique_ptr<TimeSeries> series;
  std::unique_ptr<TrajectoryWriter> trajectory;
};

// Collective: rank 0 takes the directory's lock, writes scene.toml and opens the time series
// and the trajectory in `dir`, fresh (`resumed` null; refuses a directory holding a run
// unless `force`) or cut back to what `resumed` recorded at checkpoint step `step`. Every
// rank learns whether it worked and throws SceneError if not (a directory locked by another
// process is left as it was).
RunFiles open_run_files(Communicator &comm, const std::filesystem::path &dir, const Scene &scene,
                        bool force, const RunState *resumed, long long step);

// angular.json: the |cos theta| histogram over production samples (rank 0; nothing if empty).
void write_angular(const std::filesystem::path &dir, const AngularCounts &angular);

}  // namespace hardrod
