#include "runtime/run.hpp"

#include <fmt/format.h>
#include <omp.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include "kernels/block_average.hpp"
#include "kernels/fourier_order_tensor.hpp"
#include "kernels/order_tensor.hpp"
#include "perf/counters.hpp"
#include "perf/topology.hpp"
#include "runtime/checkpoint.hpp"
#include "runtime/frank_io.hpp"
#include "runtime/simulation.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

// JSON for the state types a checkpoint holds (ADL finds these in namespace hardrod).
// ExactSum travels as its 128-bit integer in two hex words, so it comes back bit for bit.
static void to_json(nlohmann::json &j, const ExactSum &e) {
  const auto raw = static_cast<UInt128>(e.raw());
  j = {{"high", fmt::format("{:016x}", static_cast<std::uint64_t>(raw >> 64))},
       {"low", fmt::format("{:016x}", static_cast<std::uint64_t>(raw))},
       {"poisoned", e.poisoned()}};
}
static void from_json(const nlohmann::json &j, ExactSum &e) {
  const auto hi = std::stoull(j.at("high").get<std::string>(), nullptr, 16);
  const auto lo = std::stoull(j.at("low").get<std::string>(), nullptr, 16);
  const UInt128 raw = (static_cast<UInt128>(hi) << 64) | lo;
  e = ExactSum::from_raw(static_cast<Int128>(raw), j.at("poisoned").get<bool>());
}
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(IntervalTotals, steps, collisions, narrow_phase_tests, contacts,
                                   multi_contact_bodies, clusters, solver_iterations_max,
                                   solver_unconverged, max_depth, solver_energy_change, virial)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(ThermostatRecord, correction_sum, applications)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(AngularCounts, counts, total, invalid)

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

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

// Everything the run accumulates besides the bodies: the contents of a checkpoint's
// run_state (identical on every rank), so that a resumed run ends with the same numbers.
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
};

// Keys absent from a checkpoint keep their defaults, so that a checkpoint of an earlier build
// (without the bookkeeping keys added since, e.g. setup_seconds) resumes; the physics keys
// are required (kRequiredRunKeys, checked before reading).
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunState, s_series, p_series, z_series, collisions,
                                                production_collisions, narrow_tests, contacts,
                                                multi_bodies, clusters, solver_iterations_max,
                                                solver_unconverged, max_depth, solver_energy_change,
                                                running_sum, running_count, kinetic_start, angular,
                                                wall_seconds, setup_seconds, segments, list_builds,
                                                timeseries_bytes, trajectory_frames)

constexpr std::array kRequiredRunKeys = {"s_series",
                                         "p_series",
                                         "z_series",
                                         "collisions",
                                         "production_collisions",
                                         "narrow_tests",
                                         "contacts",
                                         "multi_bodies",
                                         "clusters",
                                         "solver_iterations_max",
                                         "solver_unconverged",
                                         "max_depth",
                                         "solver_energy_change",
                                         "running_sum",
                                         "running_count",
                                         "kinetic_start",
                                         "angular",
                                         "timeseries_bytes",
                                         "trajectory_frames"};

// A checkpoint's run_state: the run's accumulators, the simulation's totals of the sampling
// interval in progress (all ranks) and the thermostat record.
struct SavedState {
  RunState run;
  IntervalTotals interval;
  ThermostatRecord thermostat;
};
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(SavedState, run, interval, thermostat)

std::string duration_text(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const auto s = static_cast<long long>(seconds + 0.5);
  if (s >= 3600) return fmt::format("{}h{:02}m", s / 3600, (s / 60) % 60);
  if (s >= 60) return fmt::format("{}m{:02}s", s / 60, s % 60);
  return fmt::format("{}s", s);
}

nlohmann::json estimate_json(const Estimate &e) {
  return {{"mean", e.mean},
          {"error", std::isfinite(e.error) ? nlohmann::json(e.error) : nlohmann::json(nullptr)},
          {"samples", e.samples},
          {"converged", e.converged}};
}

// Refuse to overwrite an earlier run unless asked to: nothing already written is lost.
void prepare_output_dir(const fs::path &dir, bool force) {
  std::error_code ec;
  if (!force && (fs::exists(dir / "summary.json", ec) || fs::exists(dir / "timeseries.csv", ec)))
    throw SceneError(
        {fmt::format("output.dir = \"{}\": already holds a run (summary.json or timeseries.csv); "
                     "choose another with --out DIR, or pass --force to overwrite it",
                     dir.string())});
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw SceneError({fmt::format("output.dir = \"{}\": cannot create directory ({})", dir.string(),
                                  ec.message())});
}

class TimeSeries {
 public:
  static constexpr const char *kHeader =
      "step,time,phase,order_parameter,pressure_star,pressure_star_running,"
      "kinetic_energy,temperature,collisions,max_overlap\n";
  // A new file with the header, or (resume) the existing one cut back to `keep_bytes`.
  TimeSeries(const fs::path &path, long long keep_bytes) {
    if (keep_bytes >= 0) {
      std::error_code ec;
      const auto size = fs::file_size(path, ec);
      if (ec || static_cast<long long>(size) < keep_bytes)
        fmt::print(stderr,
                   "hardrod: warning: {} has {} bytes, the checkpoint recorded {}; appending to "
                   "what is there\n",
                   path.string(), ec ? 0 : size, keep_bytes);
      else
        fs::resize_file(path, static_cast<std::uintmax_t>(keep_bytes));
      out_.open(path, std::ios::app);
    } else {
      out_.open(path);
      out_ << kHeader;
      out_.flush();
    }
    if (!out_) throw SceneError({fmt::format("cannot write {}", path.string())});
  }
  void write(const Sample &s, double dt, double running) {
    out_ << fmt::format("{},{:.10g},{},{:.8f},{:.8f},{:.8f},{:.10g},{:.8f},{},{:.6g}\n", s.step,
                        static_cast<double>(s.step) * dt,
                        s.production ? "production" : "equilibration", s.order_parameter,
                        s.pressure_star, running, s.kinetic_energy, s.temperature, s.collisions,
                        s.max_depth);
    out_.flush();  // a killed run keeps every sample it took
  }
  long long bytes() { return static_cast<long long>(out_.tellp()); }

 private:
  std::ofstream out_;
};

// The trajectory of a resumed run: the existing file cut back to the checkpoint's frames. A
// file that cannot be reopened (a job killed while writing it) is kept under another name
// and a new one is started, so nothing already written is lost.
std::unique_ptr<TrajectoryWriter> reopen_trajectory(const fs::path &path, const Scene &scene,
                                                    long long frames, long long step) {
  try {
    return std::make_unique<TrajectoryWriter>(path.string(), scene, frames);
  } catch (const std::exception &e) {
    const fs::path aside = path.string() + fmt::format(".before-step-{}", step);
    std::error_code ec;
    fs::rename(path, aside, ec);
    fmt::print(stderr, "hardrod: warning: {}; kept it as {} and started a new trajectory\n",
               e.what(), aside.string());
    return std::make_unique<TrajectoryWriter>(path.string(), scene);
  }
}

// Writes `text` to `path` through a temporary file and a rename.
void write_atomically(const fs::path &path, const std::string &text) {
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp);
    out << text;
    if (!out) throw SceneError({fmt::format("cannot write {}", tmp.string())});
  }
  fs::rename(tmp, path);
}

nlohmann::json execute(const Scene &scene, const RunOptions &options, const Checkpoint *from) {
  const auto setup_start = Clock::now();  // the initial configuration's cost counts too
  const fs::path dir = options.output_dir.empty() ? scene.output_dir : options.output_dir;
  std::unique_ptr<Simulation> owned_sim =
      from ? std::make_unique<Simulation>(scene, from->bodies, options.parallel, from->step)
           : std::make_unique<Simulation>(scene, options.parallel);
  Simulation &sim = *owned_sim;
  Communicator &comm = sim.comm();
  const bool root = comm.is_root();

  // The run's accumulators: fresh, or the checkpoint's.
  constexpr int kAngularBins = 50;
  RunState st;
  st.angular.counts.assign(kAngularBins, 0);
  std::unique_ptr<FrankAccumulator> frank;
  if (from) {
    try {
      const auto state = nlohmann::json::parse(from->run_state);
      for (const char *key : kRequiredRunKeys)
        if (!state.at("run").contains(key))
          throw std::invalid_argument(fmt::format("run.{} is missing", key));
      const auto saved = state.get<SavedState>();
      st = saved.run;
      if (static_cast<int>(st.angular.counts.size()) != kAngularBins)
        throw std::invalid_argument("angular_counts has the wrong number of bins");
      sim.restore_interval(saved.interval);
      sim.restore_thermostat_record(saved.thermostat);
      if (scene.frank && root) {
        if (from->root_state.empty())
          throw std::invalid_argument("the Frank accumulator is missing");
        frank = std::make_unique<FrankAccumulator>(
            frank_accumulator_from_json(nlohmann::json::parse(from->root_state)));
      }
    } catch (const std::exception &e) {
      throw CheckpointError(
          fmt::format("checkpoint at step {}: run_state unusable: {}", from->step, e.what()));
    }
  } else {
    st.kinetic_start = sim.kinetic_energy();
    if (scene.frank && root)
      frank = std::make_unique<FrankAccumulator>(scene.box, scene.n, scene.fourier_kmax);
  }
  const long long first_step = sim.current_step();

  // Rank 0 owns the output; every rank learns whether it could be prepared.
  std::string dir_problem;
  std::unique_ptr<TimeSeries> series;
  std::unique_ptr<TrajectoryWriter> trajectory;
  if (root) {
    try {
      if (from) {
        write_atomically(dir / "scene.toml", scene_to_toml(scene));
        series = std::make_unique<TimeSeries>(dir / "timeseries.csv", st.timeseries_bytes);
        trajectory =
            reopen_trajectory(dir / "trajectory.h5", scene, st.trajectory_frames, from->step);
      } else {
        prepare_output_dir(dir, options.force);
        write_atomically(dir / "scene.toml", scene_to_toml(scene));
        series = std::make_unique<TimeSeries>(dir / "timeseries.csv", -1);
        trajectory = std::make_unique<TrajectoryWriter>((dir / "trajectory.h5").string(), scene);
      }
    } catch (const SceneError &e) {
      dir_problem = e.problems().front();
    } catch (const std::exception &e) {
      dir_problem = e.what();
    }
  }
  if (comm.sum("setup", dir_problem.empty() ? 0LL : 1LL) > 0)
    throw SceneError({root ? dir_problem : "output directory could not be prepared (rank 0)"});
  // Where the threads run: bind (unless told not to), then every rank reports.
  const std::string binding = bind_threads(options.bind);
  std::vector<std::string> placements;
  {
    const std::string mine = fmt::format("rank {}: {}", comm.rank(), thread_placement());
    const std::vector<char> all = comm.gather("setup", std::vector<char>(mine.begin(), mine.end()));
    // Rank lines are gathered as one block; split them at the "rank " prefixes.
    const std::string text(all.begin(), all.end());
    for (std::size_t pos = 0; pos < text.size();) {
      const std::size_t next = text.find("rank ", pos + 1);
      placements.push_back(text.substr(pos, next == std::string::npos ? next : next - pos));
      pos = next == std::string::npos ? text.size() : next;
    }
  }
  const TopologySummary topology = describe_topology();
  long long last_frame_step = -1;
  // Collective: bodies gathered in id order, one H5MD frame written by rank 0.
  auto write_frame = [&]() {
    ScopedRegion r(sim.timers(), Region::kOutput);
    const Particles bodies = sim.gather_bodies();
    if (trajectory) trajectory->append(bodies, sim.current_step(), sim.time());
    last_frame_step = sim.current_step();
  };
  // Collective: the bodies in id order and every accumulator, atomically to dir/checkpoint.h5.
  double setup_seconds = 0.0;  // measured when the steps start
  auto write_checkpoint_now = [&](double wall_now) {
    ScopedRegion r(sim.timers(), Region::kOutput);
    sim.report_pending_problems();  // never checkpoint a state that already broke
    Checkpoint c;
    c.step = sim.current_step();
    c.n = scene.n;
    c.state_checksum = sim.state_checksum();
    c.scene_toml = scene_to_toml(scene);
    RunState saved = st;
    saved.wall_seconds = st.wall_seconds + comm.max("checkpoint", {wall_now})[0];
    saved.setup_seconds = st.setup_seconds + setup_seconds;
    saved.segments = st.segments + 1;
    saved.list_builds = st.list_builds + sim.neighbor_list().builds;
    // Rank 0's byte and frame counts for everyone (the state must be the same on all ranks).
    const long long bytes = comm.sum("checkpoint", series ? series->bytes() : 0LL);
    const long long frames = comm.sum("checkpoint", trajectory ? trajectory->frames() : 0LL);
    saved.timeseries_bytes = bytes;
    saved.trajectory_frames = frames;
    c.run_state =
        nlohmann::json(SavedState{saved, sim.pending_interval(), sim.thermostat_record()}).dump();
    if (frank) c.root_state = to_json(*frank).dump();
    write_checkpoint(comm, dir, sim.particles(), sim.owned_count(), c);
  };
  const long long fourier_every =
      scene.fourier_interval > 0 ? scene.fourier_interval : scene.sample_interval;

  const long long total_steps = scene.equilibration_steps + scene.steps;
  const double eta = scene.packing_fraction();
  const double n = static_cast<double>(scene.n);
  const bool quiet = options.quiet || !root;
  const bool live = options.progress == 1 || (options.progress == -1 && isatty(fileno(stdout)));
  long long log_every = scene.log_interval;
  if (log_every <= 0) log_every = std::max<long long>(scene.sample_interval, total_steps / 20);

  std::optional<Sample> last_sample;  // for the progress line

  if (!quiet) {
    fmt::print(
        "hardrod: {} (L/D = {:g}), N = {}, rho* = {:.4f}, eta = {:.4f}, box {:.4f} x "
        "{:.4f} x {:.4f}\n",
        scene.shape.is_sphere() ? "hard spheres" : "hard spherocylinders", scene.shape.length,
        scene.n, scene.reduced_density(), eta, scene.box.length.x, scene.box.length.y,
        scene.box.length.z);
    fmt::print(
        "hardrod: dt = {:g}, {} equilibration + {} production steps, {} rank(s) x {} thread(s), "
        "output {}\n",
        scene.dt, scene.equilibration_steps, scene.steps, comm.size(), omp_get_max_threads(),
        dir.string());
    if (from)
      fmt::print("hardrod: resumed from the checkpoint at step {} (state checksum {})\n",
                 from->step, from->state_checksum);
    if (comm.size() > 1) fmt::print("hardrod: {}\n", sim.domain().describe());
    fmt::print("hardrod: machine {}; {}\n", topology.description, binding);
    for (const auto &p : placements) fmt::print("hardrod:   {}\n", p);
    std::fflush(stdout);
  }

  HardwareCounters counters;
  counters.start();
  const auto start = Clock::now();
  setup_seconds =
      comm.max("setup", {std::chrono::duration<double>(start - setup_start).count()})[0];
  auto seconds_since_start = [&start]() {
    return std::chrono::duration<double>(Clock::now() - start).count();
  };
  auto last_print = start;
  std::string failure;
  std::string stopped_by;  // the signal that interrupted the run

  auto take_sample = [&](bool production) {
    ScopedRegion r(sim.timers(), Region::kObserve);
    const Observation o = sim.observe();  // collective: the same numbers on every rank
    const IntervalTotals &t = o.totals;
    st.collisions += t.collisions;
    st.narrow_tests += t.narrow_phase_tests;
    st.contacts += t.contacts;
    st.multi_bodies += t.multi_contact_bodies;
    st.clusters += t.clusters;
    st.solver_iterations_max = std::max(st.solver_iterations_max, t.solver_iterations_max);
    st.solver_unconverged += t.solver_unconverged;
    st.solver_energy_change += t.solver_energy_change;
    st.max_depth = std::max(st.max_depth, t.max_depth);
    if (production) st.production_collisions += t.collisions;
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
                      s.step, scene.dt));
    const double interval_time = static_cast<double>(t.steps) * scene.dt;
    const double z = 1.0 + t.virial.value() / (3.0 * n * s.temperature * interval_time);
    s.pressure_star = eta * z;
    s.collisions = st.collisions;
    s.max_depth = t.max_depth;
    if (production) st.angular += sim.angular_distribution(o.director, kAngularBins);
    if (production && t.steps == scene.sample_interval) {
      st.s_series.push_back(s.order_parameter);
      st.p_series.push_back(s.pressure_star);
      st.z_series.push_back(z);
    }
    st.running_sum += s.pressure_star;
    ++st.running_count;
    if (series) series->write(s, scene.dt, st.running_sum / st.running_count);
    last_sample = s;
  };

  auto progress = [&](bool final_line) {
    const auto now = Clock::now();
    const double elapsed = std::chrono::duration<double>(now - start).count();
    const long long done = sim.current_step();
    const double rate = elapsed > 0 ? static_cast<double>(done - first_step) / elapsed : 0.0;
    const double eta_s = rate > 0 ? static_cast<double>(total_steps - done) / rate : 0.0;
    const Sample *last = last_sample ? &*last_sample : nullptr;
    const std::string line = fmt::format(
        "step {:>{}}/{} {:<5} t = {:.4g} tau  {:.3g} steps/s  ETA {:<7} S = {}  P* = {}", done,
        std::to_string(total_steps).size(), total_steps,
        done <= scene.equilibration_steps ? "equil" : "prod", sim.time(), rate,
        duration_text(eta_s), last ? fmt::format("{:.4f}", last->order_parameter) : "-",
        st.running_count ? fmt::format("{:.4f}", st.running_sum / st.running_count) : "-");
    if (live)
      fmt::print("\r{}\033[K{}", line, final_line ? "\n" : "");
    else
      fmt::print("{}\n", line);
    std::fflush(stdout);
    last_print = now;
  };

  try {
    // A step that closes a sampling interval: every sample_interval steps counted from the
    // start of production, in equilibration too (its samples go to the time series only).
    auto on_schedule = [&](long long step) {
      return (step - scene.equilibration_steps) % scene.sample_interval == 0;
    };
    // Steps run in bursts up to the next one after which something reads the state (a
    // frame, a Fourier sample, a sample, a checkpoint, a log line), at most kBurst long so
    // that a signal is seen promptly; Simulation::advance fuses the half steps in between.
    // Every term is at least one step.
    constexpr long long kBurst = 64;
    auto steps_to = [&](long long interval, long long origin) {
      if (interval <= 0) return kBurst;
      // The next step s with (s - origin) a multiple of interval, either side of origin.
      const long long into = ((sim.current_step() - origin) % interval + interval) % interval;
      return interval - into;
    };
    while (sim.current_step() < total_steps) {
      long long burst = std::min({steps_to(kBurst, 0), total_steps - sim.current_step(),
                                  steps_to(scene.snapshot_interval, 0),
                                  steps_to(scene.sample_interval, scene.equilibration_steps),
                                  steps_to(scene.checkpoint_interval, 0)});
      if (scene.frank) burst = std::min(burst, steps_to(fourier_every, scene.equilibration_steps));
      if (!quiet && !live) burst = std::min(burst, steps_to(log_every, 0));
      if (options.verify) burst = 1;
      sim.request_stop(stop_signal() != 0);
      sim.advance(burst);
      if (options.verify) sim.verify_bodies();
      const long long step = sim.current_step();
      if (scene.snapshot_interval > 0 && step % scene.snapshot_interval == 0) write_frame();
      if (scene.frank && step > scene.equilibration_steps &&
          (step - scene.equilibration_steps) % fourier_every == 0) {
        ScopedRegion r(sim.timers(), Region::kFourier);
        const OrderParameter q = sim.order();
        const FourierOrderTensor qk = sim.fourier_order(scene.fourier_kmax);
        if (frank) frank->add_sample(qk, q.director, q.S);
      }
      if (step == scene.equilibration_steps) {
        take_sample(false);  // closes equilibration; production intervals start clean
        st.running_sum = 0.0;
        st.running_count = 0;
      } else if (on_schedule(step)) {
        take_sample(step > scene.equilibration_steps);
      }
      // Checkpoints: on schedule, at the end, and when a signal asked for a stop. Taken
      // before a last partial sample, so that a resume continues the same intervals.
      const bool stop = sim.stop_agreed();
      if (stop || step == total_steps ||
          (scene.checkpoint_interval > 0 && step % scene.checkpoint_interval == 0))
        write_checkpoint_now(seconds_since_start());
      if (stop) {
        stopped_by = stop_signal_name();
        break;
      }
      if (!quiet) {
        if (live) {
          if ((step & 63) == 0 &&
              std::chrono::duration<double>(Clock::now() - last_print).count() > 0.5)
            progress(false);
        } else if (step % log_every == 0) {
          progress(false);
        }
      }
    }
    // A last, shorter interval (not in the block averages, but in the totals).
    if (stopped_by.empty() && sim.current_step() == total_steps && !on_schedule(total_steps))
      take_sample(total_steps > scene.equilibration_steps);
    if (!quiet && live) progress(true);
  } catch (const PhysicsError &e) {
    failure = e.what();
    if (!quiet && live) fmt::print("\n");
  }

  counters.stop();
  // The final state, also after a physics failure (for a post-mortem).
  if (last_frame_step != sim.current_step() && stopped_by.empty()) write_frame();
  const double wall = comm.max("summary", {seconds_since_start()})[0];
  const long long steps_done = sim.current_step();
  const double production_time =
      static_cast<double>(std::max<long long>(0, steps_done - scene.equilibration_steps)) *
      scene.dt;
  const double simulated = sim.time();
  const double particle_steps = n * static_cast<double>(steps_done - first_step);

  // Energy drift: relative kinetic-energy change per tau that the thermostat had to undo,
  // or, with the thermostat off, the change over the whole run.
  double drift = 0.0;
  const ThermostatRecord &thermostat = sim.thermostat_record();
  if (thermostat.applications > 0) {
    drift = thermostat.correction_sum / (static_cast<double>(thermostat.applications) *
                                         static_cast<double>(scene.thermostat_interval) * scene.dt);
  } else if (simulated > 0) {
    drift = (sim.kinetic_energy() / st.kinetic_start - 1.0) / simulated;
  }

  const Estimate s_est = block_average(st.s_series);
  const Estimate p_est = block_average(st.p_series);
  const Estimate z_est = block_average(st.z_series);
  const EquilibrationCheck s_eq = check_equilibration(st.s_series);
  const EquilibrationCheck p_eq = check_equilibration(st.p_series);

  const std::string status =
      !failure.empty() ? "failed" : (!stopped_by.empty() ? "interrupted" : "completed");
  nlohmann::json summary = {
      {"status", status},
      {"shape", scene.shape_name},
      {"n", scene.n},
      {"aspect_ratio", scene.shape.length},
      {"box", {scene.box.length.x, scene.box.length.y, scene.box.length.z}},
      {"reduced_density", scene.reduced_density()},
      {"packing_fraction", eta},
      {"dt", scene.dt},
      {"seed", scene.seed},
      {"equilibration_steps", scene.equilibration_steps},
      {"steps", scene.steps},
      {"steps_done", steps_done},
      {"simulated_time", simulated},
      {"production_time", production_time},
      {"pressure_star", estimate_json(p_est)},
      {"order_parameter", estimate_json(s_est)},
      {"compressibility_factor", estimate_json(z_est)},
      {"equilibrated", s_eq.equilibrated && p_eq.equilibrated},
      {"collisions", st.collisions},
      {"collision_rate", production_time > 0 ? 2.0 * static_cast<double>(st.production_collisions) /
                                                   (n * production_time)
                                             : 0.0},
      {"contacts_per_step", steps_done ? static_cast<double>(st.contacts) / steps_done : 0.0},
      {"multi_contact_bodies", st.multi_bodies},
      {"multi_contact_clusters", st.clusters},
      {"solver_iterations_max", st.solver_iterations_max},
      {"solver_unconverged", st.solver_unconverged},
      {"solver_energy_change", st.solver_energy_change.value()},
      {"narrow_phase_tests_per_step",
       steps_done ? static_cast<double>(st.narrow_tests) / steps_done : 0.0},
      {"neighbor_list_builds", st.list_builds + sim.neighbor_list().builds},
      {"max_overlap", st.max_depth},
      {"energy_drift", drift},
      {"wall_seconds", wall},
      {"setup_seconds", setup_seconds},
      {"setup_seconds_total", st.setup_seconds + setup_seconds},
      {"wall_seconds_total", st.wall_seconds + wall},
      {"segments", st.segments + 1},
      {"first_step", first_step},
      {"particle_steps_per_second", wall > 0 ? particle_steps / wall : 0.0},
      {"ns_per_particle_step", particle_steps > 0 ? 1e9 * wall / particle_steps : 0.0},
      {"ranks", comm.size()},
      {"grid", sim.domain().grid()},
      {"balance",
       {{"mode", balance_mode_name(sim.balance_options().mode)},
        {"interval", sim.balance_options().interval},
        {"threshold", sim.balance_options().threshold},
        {"checks", sim.balance_record().checks},
        {"shifts", sim.balance_record().shifts},
        {"forced_rebuilds", sim.balance_record().forced_rebuilds},
        {"first_imbalance", sim.balance_record().first_imbalance},
        {"last_imbalance", sim.balance_record().last_imbalance},
        {"max_imbalance", sim.balance_record().max_imbalance},
        {"largest_shift", sim.balance_record().largest_shift},
        {"partner_reach", sim.domain().partner_reach()},
        {"cuts", sim.domain().cuts()}}},
      {"spanning_clusters",
       {{"exchanges", comm.sum("summary", sim.spanning_record().exchanges)},
        {"resolved", comm.sum("summary", sim.spanning_record().resolved)},
        {"multi_contact", comm.sum("summary", sim.spanning_record().multi_contact)},
        {"put_together", comm.sum("summary", sim.spanning_record().put_together)},
        {"from_results", comm.sum("summary", sim.spanning_record().from_results)}}},
      {"threads", omp_get_max_threads()},
      {"topology", topology.description},
      {"binding", binding},
      {"placement", placements},
      {"state_checksum", sim.state_checksum()},
  };
  {  // region timers: rank 0's, and over all ranks the slowest and the mean (load balance)
    const auto nregions = static_cast<std::size_t>(Region::kCount);
    std::vector<double> mine(nregions);
    std::vector<ExactSum> total(nregions);
    for (std::size_t r = 0; r < nregions; ++r) {
      mine[r] = sim.timers().seconds(static_cast<Region>(r));
      total[r].add(mine[r]);
    }
    const std::vector<double> slowest = comm.max("summary", mine);
    total = comm.sum("summary", total);
    nlohmann::json timers, most, mean;
    for (std::size_t r = 0; r < nregions; ++r) {
      const char *name = region_name(static_cast<Region>(r));
      timers[name] = mine[r];
      most[name] = slowest[r];
      mean[name] = total[r].value() / comm.size();
    }
    summary["timers"] = timers;
    summary["timers_rank_max"] = most;
    summary["timers_rank_mean"] = mean;
  }
  {  // the share of detections that went through the watches, over all ranks
    const long long all = comm.sum("summary", sim.detections());
    const long long watched = comm.sum("summary", sim.detections_watched());
    summary["detect_watched_share"] = all > 0 ? static_cast<double>(watched) / all : 0.0;
  }
  nlohmann::json hw;
  hw["available"] = counters.available();
  if (counters.available())
    for (const auto &[name, value] : counters.values()) hw[name] = value;
  else
    hw["reason"] = counters.reason();
  summary["hardware_counters"] = hw;  // rank 0's threads
  // Communication per step per rank, averaged over ranks, by communication step.
  nlohmann::json traffic = nlohmann::json::object();
  const double rank_steps =
      static_cast<double>(comm.size()) * std::max<long long>(1, steps_done - first_step);
  for (const char *name : {"agree", "migrate", "shadows", "contacts", "results", "observe",
                           "kinetic_energy", "checkpoint", "balance"}) {
    const auto it = comm.traffic().find(name);
    const TrafficCounter c = it == comm.traffic().end() ? TrafficCounter{} : it->second;
    const long long messages = comm.sum("summary", c.messages);
    const long long bytes = comm.sum("summary", c.bytes);
    traffic[name] = {{"messages_per_step", static_cast<double>(messages) / rank_steps},
                     {"bytes_per_step", static_cast<double>(bytes) / rank_steps}};
  }
  summary["communication_per_rank"] = traffic;
  if (!failure.empty()) summary["error"] = failure;
  if (!stopped_by.empty()) summary["stopped_by"] = stopped_by;
  if (frank) {
    save_frank_accumulator(*frank, (dir / "frank.json").string());
    summary["frank_samples"] = frank->samples();
  }
  if (root && st.angular.total > 0) {
    nlohmann::json a;
    a["bins"] = kAngularBins;
    a["description"] =
        "distribution of |cos theta| between axes and the director over production samples, "
        "normalised so that the isotropic distribution is 1 in every bin";
    a["normalised"] = st.angular.normalised();
    a["total"] = st.angular.total;
    write_atomically(dir / "angular.json", a.dump(1) + "\n");
  }
  if (root) write_atomically(dir / "summary.json", summary.dump(2) + "\n");

  if (!quiet) {
    fmt::print("\n{}", sim.timers().table(particle_steps));
    fmt::print("counters: {}\n", counters.report());
    if (comm.size() > 1) {
      const BalanceRecord &b = sim.balance_record();
      if (sim.balance_options().mode == BalanceMode::kOff)
        fmt::print("load balance: off (--balance off)\n");
      else
        fmt::print(
            "load balance ({}): {} checks, {} shifts of the cuts ({} with a rebuild of their "
            "own); busiest rank above the mean by {:.1f} % at the first check, {:.1f} % at the "
            "last\n",
            balance_mode_name(sim.balance_options().mode), b.checks, b.shifts, b.forced_rebuilds,
            100 * b.first_imbalance, 100 * b.last_imbalance);
      const auto &sc = summary["spanning_clusters"];
      fmt::print(
          "clusters across ranks: {} resolved from merged contact records ({} with several "
          "contacts, {} needing another rank's contact), {} bodies set by the results "
          "exchange (summed over ranks)\n",
          sc["resolved"].get<long long>(), sc["multi_contact"].get<long long>(),
          sc["put_together"].get<long long>(), sc["from_results"].get<long long>());
    }
    auto pm = [](const Estimate &e) {
      return std::isfinite(e.error) ? fmt::format("{:.4f} +/- {:.4f}", e.mean, e.error)
                                    : fmt::format("{:.4f} (no error: too few samples)", e.mean);
    };
    fmt::print("\nresults over {} production samples ({:.4g} tau):\n", st.s_series.size(),
               production_time);
    fmt::print("  order parameter S        {}\n", pm(s_est));
    fmt::print("  pressure P*              {}\n", pm(p_est));
    fmt::print("  compressibility Z        {}\n", pm(z_est));
    fmt::print("  collision rate           {:.4g} per particle per tau\n",
               summary["collision_rate"].get<double>());
    fmt::print("  max overlap              {:.3g} D\n", st.max_depth);
    fmt::print("  energy drift             {:.3g} per tau\n", drift);
    fmt::print("  equilibrated             {}\n",
               summary["equilibrated"].get<bool>()
                   ? "yes"
                   : "not sure (first and last third of production differ)");
    fmt::print("  speed                    {:.1f} ns per particle-step, {:.3g} particle-steps/s\n",
               summary["ns_per_particle_step"].get<double>(),
               summary["particle_steps_per_second"].get<double>());
    fmt::print("  state checksum           {}\n", summary["state_checksum"].get<std::string>());
    fmt::print("  summary                  {}\n", (dir / "summary.json").string());
    std::fflush(stdout);
  }
  if (!failure.empty()) throw PhysicsError(failure);
  if (!stopped_by.empty())
    throw RunInterrupted(fmt::format(
        "stopped by {} at step {} of {}; checkpoint {}; continue with: hardrod resume {}",
        stopped_by, steps_done, total_steps, (dir / kCheckpointFile).string(), dir.string()));
  return summary;
}

// Keys a resume may change: the step target and how often things are written.
const std::array<std::string, 4> kResumableKeys = {
    "run.steps", "output.checkpoint_interval", "output.snapshot_interval", "output.log_interval"};

}  // namespace

namespace {
volatile std::sig_atomic_t g_stop_signal = 0;
extern "C" void on_stop_signal(int signal) { g_stop_signal = signal; }
}  // namespace

void install_stop_signals() {
  struct sigaction action {};
  action.sa_handler = on_stop_signal;
  action.sa_flags = SA_RESETHAND;  // a second signal acts at once (Ctrl-C twice kills)
  sigemptyset(&action.sa_mask);
  for (int s : {SIGTERM, SIGUSR1, SIGINT}) sigaction(s, &action, nullptr);
}

int stop_signal() { return g_stop_signal; }

std::string stop_signal_name() {
  switch (g_stop_signal) {
    case SIGTERM:
      return "SIGTERM";
    case SIGUSR1:
      return "SIGUSR1";
    case SIGINT:
      return "SIGINT";
    default:
      return "a signal to another rank";
  }
}

nlohmann::json run_scene(const Scene &scene, const RunOptions &options) {
  return execute(scene, options, nullptr);
}

nlohmann::json resume_run(const std::string &dir, const std::vector<std::string> &overrides,
                          const RunOptions &options, const std::string &checkpoint_path) {
  std::vector<std::string> problems;
  for (const auto &o : overrides) {
    const std::string key = o.substr(0, o.find('='));
    if (std::find(kResumableKeys.begin(), kResumableKeys.end(), key) == kResumableKeys.end())
      problems.push_back(fmt::format(
          "--set {}: cannot be changed on resume (the run continues exactly); resume may "
          "change run.steps, output.checkpoint_interval, output.snapshot_interval and "
          "output.log_interval",
          o));
  }
  if (!problems.empty()) throw SceneError(problems);
  const fs::path path =
      checkpoint_path.empty() ? fs::path(dir) / kCheckpointFile : fs::path(checkpoint_path);
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw CheckpointError(fmt::format("{}: no such run directory", dir));
  if (checkpoint_path.empty() && !fs::exists(path, ec) &&
      fs::exists(fs::path(dir) / kPreviousCheckpointFile, ec))
    throw CheckpointError(fmt::format(
        "{}: missing (the job was probably killed while replacing it); the previous one is "
        "complete: hardrod resume {} --checkpoint {}",
        path.string(), dir, (fs::path(dir) / kPreviousCheckpointFile).string()));
  Checkpoint c = read_checkpoint(path);
  const Scene scene = parse_scene(c.scene_toml, overrides, path.string() + ":/scene");
  if (scene.n != c.n)
    throw CheckpointError(
        fmt::format("{}: the scene has n = {}, the bodies {}", path.string(), scene.n, c.n));
  const long long total = scene.equilibration_steps + scene.steps;
  if (total < c.step)
    throw SceneError({fmt::format(
        "run.steps = {}: the checkpoint is at step {} already (equilibration {} + production "
        "{} steps); raise run.steps to at least {}",
        scene.steps, c.step, scene.equilibration_steps, scene.steps,
        c.step - scene.equilibration_steps)});
  RunOptions o = options;
  o.output_dir = dir;
  return execute(scene, o, &c);
}

}  // namespace hardrod
