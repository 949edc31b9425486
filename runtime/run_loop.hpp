// The run loop: one segment of a run (a fresh start, or a resume from a checkpoint) as the
// protocol reads: equilibrate, then produce; sample every sample_interval steps, write frames
// and Fourier samples, checkpoint on schedule, at the end and on a stop signal; then the
// summary and the report. Collective over all MPI ranks. The step itself is the System's;
// what is accumulated is run_state.hpp's, the files run_files.hpp's, the summary and the
// printed lines run_report.hpp's.
#pragma once

#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "kernels/fourier_order_tensor.hpp"
#include "perf/clock.hpp"
#include "perf/counters.hpp"
#include "runtime/checkpoint.hpp"
#include "runtime/run.hpp"
#include "runtime/run_files.hpp"
#include "runtime/run_report.hpp"
#include "runtime/run_state.hpp"
#include "runtime/scene.hpp"
#include "runtime/system.hpp"

namespace hardrod {

class RunLoop {
 public:
  // Sets the run up: the bodies (the scene's initial state, or `from`'s), the accumulators,
  // the output files and the threads' binding; prints the header. `scene` must outlive the
  // loop. Throws SceneError (output directory) and CheckpointError (unusable run_state).
  RunLoop(const Scene &scene, const RunOptions &options, const Checkpoint *from);

  // Steps to the target or a stop, then writes summary.json and returns it (every rank the
  // same). Throws PhysicsError when the physics broke and RunInterrupted after a stop, both
  // after the summary was written.
  nlohmann::json run();

 private:
  using Clock = ProgramClock;  // the simulated time under SMPI

  void restore(const Checkpoint &from);
  void step_to_target();
  long long next_burst() const;
  void sample_if_due(long long step);
  void take_sample(bool production);
  void sample_fourier();
  void write_frame();
  void write_checkpoint();
  void check_series_written(const std::string &problem);
  std::string output_advice();
  void report_progress(long long step);
  void print_progress(bool final_line);
  nlohmann::json finish();
  void write_results(const nlohmann::json &summary);
  double seconds_since_start() const;

  // Sampling intervals close every sample_interval steps counted from the start of
  // production, in equilibration too (its samples go to the time series only).
  bool on_sample_schedule(long long step) const {
    return (step - scene_.equilibration_steps) % scene_.sample_interval == 0;
  }
  // Fourier samples (scenes with frank = true) are taken in production only.
  bool fourier_due(long long step) const {
    return scene_.frank && step > scene_.equilibration_steps &&
           (step - scene_.equilibration_steps) % fourier_every_ == 0;
  }

  const Scene &scene_;
  const RunOptions options_;
  const Clock::time_point setup_start_;  // the initial configuration's cost counts too
  const std::filesystem::path dir_;
  std::unique_ptr<System> sim_;
  RunState st_;
  std::unique_ptr<FrankAccumulator> frank_;  // rank 0, scenes with frank = true
  long long first_step_ = 0;
  long long total_steps_ = 0;
  long long fourier_every_ = 0;
  long long log_every_ = 0;
  bool quiet_ = false;
  bool live_ = false;  // a progress line rewritten in place (stdout is a terminal)
  RunFiles files_;
  Placement placement_;
  HardwareCounters counters_;
  Clock::time_point start_;
  Clock::time_point last_print_;
  double setup_seconds_ = 0.0;
  double step_seconds_ = 0.0;             // in System::advance: the steps alone, this segment
  double production_step_seconds_ = 0.0;  // of those, in production
  long long production_steps_ = 0;
  std::map<std::string, double> traffic_before_production_;  // filled as production begins
  RegionTimers timers_before_production_;                    // the same
  long long last_frame_step_ = -1;
  std::optional<Sample> last_sample_;  // for the progress line
  std::string failure_;                // the PhysicsError (or failed output) that ended the run
  bool output_failed_ = false;         // a file could not be written (all ranks know)
  bool frame_failed_ =
      false;  // that file was the trajectory: the state is whole, a checkpoint may follow
  long long last_checkpoint_step_ = -1;  // the newest complete checkpoint on disk (-1: none)
  std::string stopped_by_;               // the signal that interrupted the run
};

}  // namespace hardrod
