// A whole run of a scene: equilibration, then production; samples every sample_interval
// steps (order parameter, pressure of the interval, kinetic energy), a time series written
// as it goes, a progress line, and summary.json at the end with block-averaged errors.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "runtime/scene.hpp"
#include "runtime/simulation.hpp"

namespace hardrod {

struct RunOptions {
  std::string output_dir;    // empty: the scene's output.dir
  bool force = false;        // overwrite an existing run in output_dir
  bool quiet = false;        // no progress lines (tests)
  int progress = -1;         // -1: live line if stdout is a terminal; 0: plain lines; 1: live
  ParallelOptions parallel;  // process grid
  bool bind = true;          // bind OpenMP threads to cores with hwloc (see perf/topology.hpp)
  bool verify = false;       // check body bookkeeping after every step (slow; debugging)
};

// Runs the scene and returns the summary (also written to DIR/summary.json by rank 0;
// every rank returns the same summary). Collective over all MPI ranks. Throws
// SceneError for an unusable output directory and PhysicsError when the physics breaks
// (after writing what was measured so far).
nlohmann::json run_scene(const Scene &scene, const RunOptions &options);

}  // namespace hardrod
