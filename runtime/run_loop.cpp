// RunLoop (see run_loop.hpp): set-up, the loop over bursts of steps, and what happens
// between bursts (samples, frames, Fourier samples, checkpoints, progress lines).
#include "runtime/run_loop.hpp"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "kernels/order_tensor.hpp"
#include "perf/region_timer.hpp"
#include "runtime/frank_io.hpp"
#include "runtime/signals.hpp"

namespace hardrod {

namespace {

// Steps run in bursts up to the next one after which something reads the state (a frame,
// a Fourier sample, a sample, a checkpoint, a log line), at most kBurst long so that a
// signal is seen promptly; System::advance runs the steps in between in one call.
constexpr long long kBurst = 64;

// Steps from `now` to the next step s with (s - origin) a multiple of `interval`, either side
// of origin; at least one step (kBurst for no interval). No intermediate exceeds `interval`
// or |now - origin| (the scene bounds both), so no interval overflows it.
long long steps_to(long long now, long long interval, long long origin) {
  if (interval <= 0) return kBurst;
  long long into = (now - origin) % interval;
  if (into < 0) into += interval;
  return interval - into;
}

// Whether something written every `interval` steps (0: never) is due at `step`.
bool due_every(long long interval, long long step) { return interval > 0 && step % interval == 0; }

}  // namespace

RunLoop::RunLoop(const Scene &scene, const RunOptions &options, const Checkpoint *from)
    : scene_(scene),
      options_(options),
      setup_start_(Clock::now()),
      dir_(options.output_dir.empty() ? scene.output_dir : options.output_dir),
      sim_(from ? std::make_unique<System>(scene, from->bodies, options.parallel, from->step)
                : std::make_unique<System>(scene, options.parallel)) {
  Communicator &comm = sim_->comm();
  const bool root = comm.is_root();
  st_.angular.counts.assign(kAngularBins, 0);
  if (from) {
    restore(*from);
  } else {
    st_.kinetic_start = sim_->kinetic_energy();
    if (scene.frank && root)
      frank_ = std::make_unique<FrankAccumulator>(scene.box, scene.n, scene.fourier_kmax);
  }
  first_step_ = sim_->current_step();
  if (from) last_checkpoint_step_ = from->step;
  files_ = open_run_files(comm, dir_, scene, options.force, from ? &st_ : nullptr,
                          from ? from->step : 0);
  placement_ = place_threads(comm, options.bind);

  total_steps_ = scene.equilibration_steps + scene.steps;
  fourier_every_ = scene.fourier_interval > 0 ? scene.fourier_interval : scene.sample_interval;
  quiet_ = options.quiet || !root;
  live_ = isatty(fileno(stdout));
  log_every_ = scene.log_interval;
  if (log_every_ <= 0) log_every_ = std::max<long long>(scene.sample_interval, total_steps_ / 20);
  if (!quiet_) print_run_header(scene, *sim_, dir_, from, placement_);
}

// The checkpoint's accumulators, interval totals, thermostat record and (rank 0) Frank
// accumulator.
void RunLoop::restore(const Checkpoint &from) {
  try {
    const SavedState saved = parse_saved_state(from.run_state);
    st_ = saved.run;
    sim_->restore_interval(saved.interval);
    sim_->restore_thermostat_record(saved.thermostat);
    if (scene_.frank && sim_->comm().is_root()) {
      if (from.root_state.empty()) throw std::invalid_argument("the Frank accumulator is missing");
      frank_ = std::make_unique<FrankAccumulator>(
          frank_accumulator_from_json(nlohmann::json::parse(from.root_state)));
    }
  } catch (const std::exception &e) {
    throw CheckpointError(
        fmt::format("checkpoint at step {}: run_state unusable: {}", from.step, e.what()));
  }
}

nlohmann::json RunLoop::run() {
  counters_.start();
  start_ = Clock::now();
  last_print_ = start_;
  setup_seconds_ =
      sim_->comm().max("setup", {std::chrono::duration<double>(start_ - setup_start_).count()})[0];
  try {
    step_to_target();
  } catch (const PhysicsError &e) {
    failure_ = e.what();
    if (!quiet_ && live_) fmt::print("\n");
  } catch (const std::exception &e) {  // output that failed: thrown on every rank alike
    if (!dynamic_cast<const CheckpointError *>(&e) && !dynamic_cast<const RunOutputError *>(&e))
      throw;
    failure_ = e.what();
    output_failed_ = true;
    if (!quiet_ && live_) fmt::print("\n");
  }
  counters_.stop();
  return finish();
}

// Equilibration and production as one sequence of bursts of steps; after each burst
// whatever is due at the step it ended on, in this order.
void RunLoop::step_to_target() {
  System &sim = *sim_;
  while (sim.current_step() < total_steps_) {
    sim.request_stop(stop_signal() != 0);  // agreed on in the next step's reduction
    // The ranks start a burst together: what rank 0 alone did after the last one (writing
    // samples, frames, progress) is not waited for inside the steps.
    sim.comm().barrier("burst");
    const Clock::time_point burst = Clock::now();
    const bool production = sim.current_step() >= scene_.equilibration_steps;
    if (production && production_steps_ == 0) {
      for (const auto &[name, counter] : sim.comm().traffic())
        traffic_before_production_[name] = counter.seconds;
      timers_before_production_ = sim.timers();
    }
    const long long before = sim.current_step();
    sim.advance(next_burst());
    const double seconds = seconds_between(burst, Clock::now());
    step_seconds_ += seconds;
    if (production) {
      production_step_seconds_ += seconds;
      production_steps_ += sim.current_step() - before;
    }
    if (options_.verify) sim.verify_bodies();
    const long long step = sim.current_step();
    if (due_every(scene_.snapshot_interval, step)) write_frame();
    if (fourier_due(step)) sample_fourier();
    sample_if_due(step);
    // Checkpoints: on schedule, at the end, and when a signal asked for a stop. Taken
    // before a last partial sample, so that a resume continues the same intervals.
    const bool stop = sim.stop_agreed();
    if (stop || step == total_steps_ || due_every(scene_.checkpoint_interval, step))
      write_checkpoint();
    if (stop) {
      stopped_by_ = stop_signal_name();
      break;
    }
    report_progress(step);
  }
  // A last, shorter interval (not in the block averages, but in the totals).
  if (stopped_by_.empty() && sim.current_step() == total_steps_ &&
      !on_sample_schedule(total_steps_))
    take_sample(total_steps_ > scene_.equilibration_steps);
  if (!quiet_ && live_) print_progress(true);
}

long long RunLoop::next_burst() const {
  if (options_.verify) return 1;  // verify_bodies after every step
  const long long now = sim_->current_step();
  long long burst = std::min({steps_to(now, kBurst, 0), total_steps_ - now,
                              steps_to(now, scene_.snapshot_interval, 0),
                              steps_to(now, scene_.sample_interval, scene_.equilibration_steps),
                              steps_to(now, scene_.checkpoint_interval, 0)});
  if (scene_.frank)
    burst = std::min(burst, steps_to(now, fourier_every_, scene_.equilibration_steps));
  if (!quiet_ && !live_) burst = std::min(burst, steps_to(now, log_every_, 0));
  return burst;
}

void RunLoop::sample_if_due(long long step) {
  if (step == scene_.equilibration_steps) {
    take_sample(false);  // closes equilibration; production intervals start clean
    st_.running_sum = 0.0;
    st_.running_count = 0;
  } else if (on_sample_schedule(step)) {
    take_sample(step > scene_.equilibration_steps);
  }
}

// Collective: closes the sampling interval that ends now. Its counters go into the totals;
// a full production interval's S, P* and Z into the block-averaged series; every non-empty
// interval into the time series.
void RunLoop::take_sample(bool production) {
  System &sim = *sim_;
  ScopedRegion r(sim.timers(), Region::kObserve);
  const Observation o = sim.observe();  // collective: the same numbers on every rank
  const IntervalTotals &t = o.totals;
  st_.add_interval(t, production);
  if (t.steps == 0) return;
  Sample s;
  s.step = o.step;
  s.production = production;
  s.order_parameter = o.order_parameter;
  s.kinetic_energy = o.kinetic_energy;
  s.temperature = o.temperature;
  if (!std::isfinite(s.kinetic_energy))
    throw PhysicsError(
        fmt::format("step {}: kinetic energy is not finite at run.dt = {:g}; "
                    "try a smaller run.dt",
                    s.step, scene_.dt));
  // The pressure of the interval from the collision virial: Z = 1 + W / (3 N T t).
  const double interval_time = static_cast<double>(t.steps) * scene_.dt;
  const double n = static_cast<double>(scene_.n);
  const double z = 1.0 + t.virial.value() / (3.0 * n * s.temperature * interval_time);
  s.pressure_star = scene_.packing_fraction() * z;
  s.collisions = st_.collisions;
  s.max_depth = t.max_depth;
  if (production) st_.angular += sim.angular_distribution(o.director, kAngularBins);
  if (production && t.steps == scene_.sample_interval) {
    st_.s_series.push_back(s.order_parameter);
    st_.p_series.push_back(s.pressure_star);
    st_.z_series.push_back(z);
  }
  st_.running_sum += s.pressure_star;
  ++st_.running_count;
  std::string problem;  // rank 0's (a full disk), agreed on so that every rank stops
  try {
    if (files_.series) files_.series->write(s, scene_.dt, st_.running_sum / st_.running_count);
  } catch (const std::exception &e) {
    problem = e.what();
  }
  check_series_written(problem);
  last_sample_ = s;
}

void RunLoop::sample_fourier() {
  ScopedRegion r(sim_->timers(), Region::kFourier);
  const OrderParameter q = sim_->order();
  const FourierOrderTensor qk = sim_->fourier_order(scene_.fourier_kmax);
  if (frank_) frank_->add_sample(qk, q.director, q.S);
}

// Collective: a time series row that rank 0 could not write stops every rank.
void RunLoop::check_series_written(const std::string &problem) {
  if (sim_->comm().sum("output", problem.empty() ? 0LL : 1LL) > 0)
    throw RunOutputError(fmt::format("sample at step {} not written: {}", sim_->current_step(),
                                     problem.empty() ? "failed on rank 0" : problem));
}

// Collective: bodies gathered in id order, one H5MD frame written by rank 0. A frame that
// would not fit in the free space is not begun, so the file keeps its whole frames readable
// (HDF5 cannot undo a frame half written to a full disk).
void RunLoop::write_frame() {
  ScopedRegion r(sim_->timers(), Region::kOutput);
  const Particles bodies = sim_->gather_bodies();
  std::string problem;  // rank 0's (a full disk), agreed on so that every rank stops
  errno = 0;
  try {
    if (files_.trajectory) {
      std::error_code ec;
      const std::uintmax_t free = std::filesystem::space(dir_, ec).available;
      const std::uintmax_t needs = files_.trajectory->frame_bytes() + (1u << 16);
      if (!ec && free < needs)
        problem = fmt::format("{}: {} bytes free, a frame needs about {} (disk full)",
                              (dir_ / "trajectory.h5").string(), free, needs);
      else
        files_.trajectory->append(bodies, sim_->current_step(), sim_->time());
    }
  } catch (const std::exception &e) {
    const int why = errno;  // HDF5 says only that a write failed; the system says why
    problem = why ? fmt::format("{} ({})", e.what(), std::strerror(why)) : e.what();
  }
  frame_failed_ = sim_->comm().sum("output", problem.empty() ? 0LL : 1LL) > 0;
  if (frame_failed_)
    throw RunOutputError(fmt::format("trajectory frame at step {} not written: {}",
                                     sim_->current_step(),
                                     problem.empty() ? "failed on rank 0" : problem));
  last_frame_step_ = sim_->current_step();
}

// Collective: the bodies in id order and every accumulator, atomically to dir/checkpoint.h5.
void RunLoop::write_checkpoint() {
  const double wall_now = seconds_since_start();
  System &sim = *sim_;
  Communicator &comm = sim.comm();
  ScopedRegion r(sim.timers(), Region::kOutput);
  sim.report_pending_problems();  // never checkpoint a state that already broke
  Checkpoint c;
  c.step = sim.current_step();
  c.n = scene_.n;
  c.state_checksum = sim.state_checksum();
  c.scene_toml = scene_to_toml(scene_);
  RunState saved = st_;
  saved.wall_seconds = st_.wall_seconds + comm.max("checkpoint", {wall_now})[0];
  saved.setup_seconds = st_.setup_seconds + setup_seconds_;
  saved.segments = st_.segments + 1;
  saved.list_builds = st_.list_builds + sim.neighbor_list().builds;
  // Rank 0's byte and frame counts for everyone (the state must be the same on all ranks).
  saved.timeseries_bytes = comm.sum("checkpoint", files_.series ? files_.series->bytes() : 0LL);
  saved.trajectory_frames =
      comm.sum("checkpoint", files_.trajectory ? files_.trajectory->frames() : 0LL);
  c.run_state = saved_state_json({saved, sim.pending_interval(), sim.thermostat_record()});
  if (frank_) c.root_state = to_json(*frank_).dump();
  hardrod::write_checkpoint(comm, dir_, sim.particles(), sim.owned_count(), c);
  last_checkpoint_step_ = c.step;
}

// Collective, after a failed write: what the user can do, made true first. Where the
// trajectory failed (the state and the accumulators are whole), a checkpoint of the current
// step is tried: it replaces the last one atomically, so its failure loses nothing.
std::string RunLoop::output_advice() {
  if (frame_failed_ && last_checkpoint_step_ != sim_->current_step()) {
    try {
      write_checkpoint();
    } catch (const CheckpointError &e) {
      failure_ +=
          fmt::format("; no checkpoint at step {} either ({})", sim_->current_step(), e.what());
    }
  }
  if (last_checkpoint_step_ < 0)
    return fmt::format(
        "no checkpoint was written: once there is room, run again with --out {} "
        "--force",
        dir_.string());
  return fmt::format(
      "the checkpoint of step {} is on disk: once there is room, continue with: "
      "hardrod resume {}",
      last_checkpoint_step_, dir_.string());
}

void RunLoop::report_progress(long long step) {
  if (quiet_) return;
  if (live_) {
    if ((step & 63) == 0 && std::chrono::duration<double>(Clock::now() - last_print_).count() > 0.5)
      print_progress(false);
  } else if (step % log_every_ == 0) {
    print_progress(false);
  }
}

void RunLoop::print_progress(bool final_line) {
  const auto now = Clock::now();
  Progress p;
  p.step = sim_->current_step();
  p.first_step = first_step_;
  p.total_steps = total_steps_;
  p.equilibration_steps = scene_.equilibration_steps;
  p.time = sim_->time();
  p.elapsed = std::chrono::duration<double>(now - start_).count();
  if (last_sample_) p.order_parameter = last_sample_->order_parameter;
  if (st_.running_count) p.running_pressure = st_.running_sum / st_.running_count;
  const std::string line = progress_line(p);
  if (live_)
    fmt::print("\r{}\033[K{}", line, final_line ? "\n" : "");
  else
    fmt::print("{}\n", line);
  std::fflush(stdout);
  last_print_ = now;
}

// The final frame, summary.json (and frank.json, angular.json), the report; then the
// exception that says how the run ended, if it did not complete.
nlohmann::json RunLoop::finish() {
  System &sim = *sim_;
  // The final state, also after a physics failure (for a post-mortem); not after a failed
  // write (the disk is full).
  try {
    if (last_frame_step_ != sim.current_step() && stopped_by_.empty() && !output_failed_)
      write_frame();
  } catch (const RunOutputError &e) {
    failure_ = e.what();
    output_failed_ = true;
  }
  RunOutcome outcome;
  outcome.failure = failure_;
  outcome.stopped_by = stopped_by_;
  outcome.first_step = first_step_;
  outcome.wall_seconds = sim.comm().max("summary", {seconds_since_start()})[0];
  outcome.setup_seconds = setup_seconds_;
  const std::vector<double> steps =
      sim.comm().max("summary", {step_seconds_, production_step_seconds_});
  outcome.step_seconds = steps[0];
  outcome.production_seconds_per_step =
      production_steps_ > 0 ? steps[1] / static_cast<double>(production_steps_) : 0.0;
  outcome.production_steps = production_steps_;
  outcome.production_step_seconds_here = production_step_seconds_;
  outcome.traffic_seconds_before_production = traffic_before_production_;
  outcome.timers_before_production = timers_before_production_;
  nlohmann::json summary = run_summary(scene_, sim, st_, outcome, placement_, counters_);
  if (frank_) summary["frank_samples"] = frank_->samples();
  try {
    write_results(summary);
  } catch (const std::exception &e) {
    if (!output_failed_) throw;
    failure_ += fmt::format("; the summary was not written either ({})", e.what());
  }
  if (!quiet_) print_run_report(sim, st_, summary, counters_, dir_);
  if (output_failed_) {
    const std::string advice = output_advice();
    throw RunOutputError(fmt::format("{}; {}", failure_, advice));
  }
  if (!failure_.empty()) throw PhysicsError(failure_);
  if (!stopped_by_.empty())
    throw RunInterrupted(fmt::format(
        "stopped by {} at step {} of {}; checkpoint {}; continue with: hardrod resume {}",
        stopped_by_, sim.current_step(), total_steps_, (dir_ / kCheckpointFile).string(),
        dir_.string()));
  return summary;
}

// frank.json (rank 0 holds the accumulator), angular.json and summary.json.
void RunLoop::write_results(const nlohmann::json &summary) {
  if (frank_) save_frank_accumulator(*frank_, (dir_ / "frank.json").string());
  if (!sim_->comm().is_root()) return;
  write_angular(dir_, st_.angular);
  write_atomically(dir_ / "summary.json", summary.dump(2) + "\n");
}

double RunLoop::seconds_since_start() const {
  return std::chrono::duration<double>(Clock::now() - start_).count();
}

}  // namespace hardrod
