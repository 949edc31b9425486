// What a run accumulates besides the bodies, and what a checkpoint carries for the run: the
// production series, the counters of every sampling interval, the angular histogram, the
// bookkeeping of earlier segments and how much output was already written. Identical on
// every rank. The run loop (run_loop.hpp) fills it; this file only defines it, adds one
// interval's totals to it and converts it to and from the checkpoint's run_state JSON.
// The bodies, the scene and the Frank accumulator travel in the checkpoint separately.
#pragma once

#include <string>
#include <vector>

#include "kernels/exact_sum.hpp"
#include "kernels/order_tensor.hpp"
#include "runtime/system.hpp"

namespace hardrod {

// Bins of the |cos theta| histogram between axes and director (angular.json).
inline constexpr int kAngularBins = 50;

struct RunState {
  std::vector<double> s_series, p_series, z_series;  // production samples
  long long collisions = 0, production_collisions = 0, narrow_tests = 0, contacts = 0,
            multi_bodies = 0, clusters = 0, solver_iterations_max = 0, solver_unconverged = 0;
  double max_depth = 0.0;
  ExactSum solver_energy_change;
  double running_sum = 0.0;  // of P* over this phase's samples (progress line)
  long long running_count = 0;
  double kinetic_start = 0.0;
  AngularCounts angular;
  double wall_seconds = 0.0;   // of earlier segments
  double setup_seconds = 0.0;  // of earlier segments (the initial configuration's included)
  long long segments = 0;      // run + resumes before this one
  long long list_builds = 0;   // neighbour-list builds of earlier segments
  // Output already written when the checkpoint was taken: a resume cuts the files back.
  long long timeseries_bytes = 0;
  long long trajectory_frames = 0;

  // Adds the counters of one sampling interval (summed over ranks); `production` also
  // counts its collisions towards the collision rate.
  void add_interval(const IntervalTotals &t, bool production);
};

// A checkpoint's run_state: the run's accumulators, the simulation's totals of the sampling
// interval in progress (all ranks) and the thermostat record.
struct SavedState {
  RunState run;
  IntervalTotals interval;
  ThermostatRecord thermostat;
};

// The JSON text stored as a checkpoint's run_state.
std::string saved_state_json(const SavedState &state);
// Reads it back. Keys absent from a checkpoint keep their defaults, so that a checkpoint of
// an earlier build (without bookkeeping keys added since, e.g. setup_seconds) resumes; the
// physics keys are required. Throws std::exception naming what is wrong.
SavedState parse_saved_state(const std::string &json_text);

}  // namespace hardrod
