// A whole run of a scene, the entry points: a fresh run, or the resume of one from its
// checkpoint. The loop itself is RunLoop's (run_loop.hpp): equilibration, then production;
// samples every sample_interval steps (order parameter, pressure of the interval, kinetic
// energy), a time series written as it goes, a progress line, and summary.json at the end
// with block-averaged errors.
#pragma once

#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "runtime/scene.hpp"
#include "runtime/system.hpp"

namespace hardrod {

struct RunOptions {
  std::string output_dir;    // empty: the scene's output.dir
  bool force = false;        // overwrite an existing run in output_dir
  bool quiet = false;        // no progress lines (tests); a terminal gets a live line
  ParallelOptions parallel;  // process grid
  bool bind = true;          // bind OpenMP threads to cores with hwloc (see perf/topology.hpp)
  bool verify = false;       // check body bookkeeping after every step (slow; debugging)
};

// Runs the scene and returns the summary (also written to DIR/summary.json by rank 0;
// every rank returns the same summary). Collective over all MPI ranks. Throws
// SceneError for an unusable output directory and PhysicsError when the physics breaks
// (after writing what was measured so far).
nlohmann::json run_scene(const Scene &scene, const RunOptions &options);

// A run stopped on request (SIGTERM, SIGUSR1, SIGINT; see signals.hpp) after writing a
// checkpoint; the message says how to resume. Thrown on every rank after summary.json was
// written.
class RunInterrupted : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A run stopped because its output could not be written (a checkpoint on a full disk): the
// message says what and why; summary.json says "status": "failed" if it could still be
// written, and the previous checkpoint is kept. Thrown on every rank.
class RunOutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Continues the run in `dir` from its newest complete checkpoint (or `checkpoint_path`) to
// the step target of the stored scene with `overrides` (only run.steps and output
// intervals may change), exactly: the result equals the uninterrupted run's, on any rank
// or thread count. Throws CheckpointError for an unusable checkpoint and SceneError for a
// bad override, before anything in `dir` is changed.
nlohmann::json resume_run(const std::string &dir, const std::vector<std::string> &overrides,
                          const RunOptions &options, const std::string &checkpoint_path = "");

}  // namespace hardrod
