// What a run tells its user: the header printed at the start (scene, machine, where the
// threads run), the progress line, summary.json's contents and the report printed at the
// end. Only formatting and the summary's arithmetic (block-averaged estimates, rates, energy
// drift); the run loop (run_loop.hpp) decides when each is written and owns the files.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "kernels/block_average.hpp"
#include "perf/counters.hpp"
#include "runtime/checkpoint.hpp"
#include "runtime/run_state.hpp"
#include "runtime/scene.hpp"
#include "runtime/system.hpp"

namespace hardrod {

// "42s", "3m07s", "2h05m"; "?" for a negative or non-finite time.
std::string duration_text(double seconds);

// {"mean", "error" (null when not finite), "samples", "converged"}.
nlohmann::json estimate_json(const Estimate &e);

// Where the threads run: the machine, the binding and one line per rank.
struct Placement {
  std::string topology;
  std::string binding;
  std::vector<std::string> ranks;  // "rank R: ..." in rank order
};

// Collective: binds the threads (unless `bind` is false) and gathers every rank's placement.
Placement place_threads(Communicator &comm, bool bind);

// The lines printed before the first step (rank 0, unless quiet).
void print_run_header(const Scene &scene, System &sim, const std::filesystem::path &dir,
                      const Checkpoint *from, const Placement &placement);

// One progress line: step, phase, time, speed, ETA, the last sample's S and the running P*.
struct Progress {
  long long step = 0, first_step = 0, total_steps = 0, equilibration_steps = 0;
  double time = 0.0;                      // simulated, tau
  double elapsed = 0.0;                   // wall seconds of this segment
  std::optional<double> order_parameter;  // of the last sample
  std::optional<double> running_pressure;
};
std::string progress_line(const Progress &p);

// How the run ended, for the summary.
struct RunOutcome {
  std::string failure;     // the PhysicsError's message; empty if none
  std::string stopped_by;  // the stop signal's name; empty if none
  long long first_step = 0;
  double wall_seconds = 0.0;   // this segment, slowest rank
  double setup_seconds = 0.0;  // this segment, slowest rank
  double step_seconds = 0.0;   // in the steps alone (no samples, output), slowest rank
  double production_seconds_per_step = 0.0;   // the same, per production step (0: none)
  long long production_steps = 0;             // this segment's
  double production_step_seconds_here = 0.0;  // in them, this rank
  // Each communication's seconds and the region timers on this rank when this segment's
  // production began.
  std::map<std::string, double> traffic_seconds_before_production;
  RegionTimers timers_before_production;
};

// Collective: summary.json's contents (the same on every rank, except the Frank sample count
// the caller adds on rank 0).
nlohmann::json run_summary(const Scene &scene, System &sim, const RunState &st,
                           const RunOutcome &outcome, const Placement &placement,
                           const HardwareCounters &counters);

// The report printed at the end (rank 0, unless quiet): the results with errors (led by
// FAILED and the reason for a failed run), then the timers, the counters and the parallel
// bookkeeping.
void print_run_report(System &sim, const RunState &st, const nlohmann::json &summary,
                      const HardwareCounters &counters, const std::filesystem::path &dir);

}  // namespace hardrod
