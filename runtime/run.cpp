#include "runtime/run.hpp"

#include <fmt/format.h>
#include <omp.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
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
#include "runtime/simulation.hpp"
#include "runtime/snapshot.hpp"

namespace hardrod {

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
  explicit TimeSeries(const fs::path &path) : out_(path) {
    if (!out_) throw SceneError({fmt::format("cannot write {}", path.string())});
    out_ << "step,time,phase,order_parameter,pressure_star,pressure_star_running,"
            "kinetic_energy,temperature,collisions,max_overlap\n";
  }
  void write(const Sample &s, double dt, double running) {
    out_ << fmt::format("{},{:.10g},{},{:.8f},{:.8f},{:.8f},{:.10g},{:.8f},{},{:.6g}\n", s.step,
                        static_cast<double>(s.step) * dt,
                        s.production ? "production" : "equilibration", s.order_parameter,
                        s.pressure_star, running, s.kinetic_energy, s.temperature, s.collisions,
                        s.max_depth);
    out_.flush();  // a killed run keeps every sample it took
  }

 private:
  std::ofstream out_;
};

}  // namespace

nlohmann::json run_scene(const Scene &scene, const RunOptions &options) {
  const fs::path dir = options.output_dir.empty() ? scene.output_dir : options.output_dir;
  Simulation sim(scene, options.parallel);
  Communicator &comm = sim.comm();
  const bool root = comm.is_root();
  // Rank 0 owns the output; every rank learns whether it could be prepared.
  std::string dir_problem;
  if (root) {
    try {
      prepare_output_dir(dir, options.force);
      std::ofstream s(dir / "scene.toml");
      s << scene_to_toml(scene);
    } catch (const SceneError &e) {
      dir_problem = e.problems().front();
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
  std::unique_ptr<TimeSeries> series;
  std::unique_ptr<TrajectoryWriter> trajectory;
  if (root) {
    series = std::make_unique<TimeSeries>(dir / "timeseries.csv");
    trajectory = std::make_unique<TrajectoryWriter>((dir / "trajectory.h5").string(), scene);
  }
  // Collective: bodies gathered in id order, one H5MD frame written by rank 0.
  auto write_frame = [&]() {
    ScopedRegion r(sim.timers(), Region::kOutput);
    const Particles bodies = sim.gather_bodies();
    if (trajectory) trajectory->append(bodies, sim.current_step(), sim.time());
  };
  // Frank constants: only when the scene asks (a scene pays only for what it uses).
  std::unique_ptr<FrankAccumulator> frank;
  if (scene.frank && root)
    frank = std::make_unique<FrankAccumulator>(scene.box, scene.n, scene.fourier_kmax);
  const long long fourier_every =
      scene.fourier_interval > 0 ? scene.fourier_interval : scene.sample_interval;
  constexpr int kAngularBins = 50;
  AngularCounts angular;
  angular.counts.assign(kAngularBins, 0);

  const long long total_steps = scene.equilibration_steps + scene.steps;
  const double eta = scene.packing_fraction();
  const double n = static_cast<double>(scene.n);
  const bool quiet = options.quiet || !root;
  const bool live = options.progress == 1 || (options.progress == -1 && isatty(fileno(stdout)));
  long long log_every = scene.log_interval;
  if (log_every <= 0) log_every = std::max<long long>(scene.sample_interval, total_steps / 20);

  std::optional<Sample> last_sample;  // for the progress line
  std::vector<double> s_series, p_series, z_series;
  long long collisions_total = 0, production_collisions = 0, narrow_tests = 0, contacts = 0,
            multi_bodies = 0, clusters = 0, solver_iterations_max = 0, solver_unconverged = 0;
  double max_depth = 0.0, solver_energy_change = 0.0;
  double running_sum = 0.0;
  long long running_count = 0;
  const double kinetic_start = sim.kinetic_energy();

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
    if (comm.size() > 1) fmt::print("hardrod: {}\n", sim.domain().describe());
    fmt::print("hardrod: machine {}; {}\n", topology.description, binding);
    for (const auto &p : placements) fmt::print("hardrod:   {}\n", p);
    std::fflush(stdout);
  }

  HardwareCounters counters;
  counters.start();
  const auto start = Clock::now();
  auto last_print = start;
  std::string failure;

  auto take_sample = [&](bool production) {
    ScopedRegion r(sim.timers(), Region::kObserve);
    const Observation o = sim.observe();  // collective: the same numbers on every rank
    const IntervalTotals &t = o.totals;
    collisions_total += t.collisions;
    narrow_tests += t.narrow_phase_tests;
    contacts += t.contacts;
    multi_bodies += t.multi_contact_bodies;
    clusters += t.clusters;
    solver_iterations_max = std::max(solver_iterations_max, t.solver_iterations_max);
    solver_unconverged += t.solver_unconverged;
    solver_energy_change += t.solver_energy_change;
    max_depth = std::max(max_depth, t.max_depth);
    if (production) production_collisions += t.collisions;
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
    s.collisions = collisions_total;
    s.max_depth = t.max_depth;
    if (production) angular += sim.angular_distribution(o.director, kAngularBins);
    if (production && t.steps == scene.sample_interval) {
      s_series.push_back(s.order_parameter);
      p_series.push_back(s.pressure_star);
      z_series.push_back(z);
    }
    running_sum += s.pressure_star;
    ++running_count;
    if (series) series->write(s, scene.dt, running_sum / running_count);
    last_sample = s;
  };

  auto progress = [&](bool final_line) {
    const auto now = Clock::now();
    const double elapsed = std::chrono::duration<double>(now - start).count();
    const long long done = sim.current_step();
    const double rate = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
    const double eta_s = rate > 0 ? static_cast<double>(total_steps - done) / rate : 0.0;
    const Sample *last = last_sample ? &*last_sample : nullptr;
    const std::string line = fmt::format(
        "step {:>{}}/{} {:<5} t = {:.4g} tau  {:.3g} steps/s  ETA {:<7} S = {}  P* = {}", done,
        std::to_string(total_steps).size(), total_steps,
        done <= scene.equilibration_steps ? "equil" : "prod", sim.time(), rate,
        duration_text(eta_s), last ? fmt::format("{:.4f}", last->order_parameter) : "-",
        running_count ? fmt::format("{:.4f}", running_sum / running_count) : "-");
    if (live)
      fmt::print("\r{}\033[K{}", line, final_line ? "\n" : "");
    else
      fmt::print("{}\n", line);
    std::fflush(stdout);
    last_print = now;
  };

  try {
    while (sim.current_step() < total_steps) {
      sim.step();
      if (options.verify) sim.verify_bodies();
      const long long step = sim.current_step();
      if (scene.snapshot_interval > 0 && step % scene.snapshot_interval == 0 && step != total_steps)
        write_frame();
      if (scene.frank && step > scene.equilibration_steps &&
          (step - scene.equilibration_steps) % fourier_every == 0) {
        ScopedRegion r(sim.timers(), Region::kFourier);
        const OrderParameter q = sim.order();
        const FourierOrderTensor qk = sim.fourier_order(scene.fourier_kmax);
        if (frank) frank->add_sample(qk, q.director, q.S);
      }
      if (step == scene.equilibration_steps) {
        take_sample(false);  // closes equilibration; production intervals start clean
        running_sum = 0.0;
        running_count = 0;
      } else if ((step - scene.equilibration_steps) % scene.sample_interval == 0 ||
                 step == total_steps) {
        take_sample(step > scene.equilibration_steps);
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
    if (!quiet && live) progress(true);
  } catch (const PhysicsError &e) {
    failure = e.what();
    if (!quiet && live) fmt::print("\n");
  }

  counters.stop();
  write_frame();  // the final state, also after a physics failure (for a post-mortem)
  const double wall =
      comm.max("summary", {std::chrono::duration<double>(Clock::now() - start).count()})[0];
  const double production_time = static_cast<double>(scene.steps) * scene.dt;
  const double simulated = sim.time();
  const double particle_steps = n * static_cast<double>(sim.current_step());

  // Energy drift: relative kinetic-energy change per tau that the thermostat had to undo,
  // or, with the thermostat off, the change over the whole run.
  double drift = 0.0;
  const auto &corrections = sim.thermostat_corrections();
  if (!corrections.empty()) {
    double sum = 0.0;
    for (double c : corrections) sum += c;
    drift = sum / (static_cast<double>(corrections.size()) *
                   static_cast<double>(scene.thermostat_interval) * scene.dt);
  } else if (simulated > 0) {
    drift = (sim.kinetic_energy() / kinetic_start - 1.0) / simulated;
  }

  const Estimate s_est = block_average(s_series);
  const Estimate p_est = block_average(p_series);
  const Estimate z_est = block_average(z_series);
  const EquilibrationCheck s_eq = check_equilibration(s_series);
  const EquilibrationCheck p_eq = check_equilibration(p_series);

  nlohmann::json summary = {
      {"status", failure.empty() ? "completed" : "failed"},
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
      {"steps_done", sim.current_step()},
      {"simulated_time", simulated},
      {"production_time", production_time},
      {"pressure_star", estimate_json(p_est)},
      {"order_parameter", estimate_json(s_est)},
      {"compressibility_factor", estimate_json(z_est)},
      {"equilibrated", s_eq.equilibrated && p_eq.equilibrated},
      {"collisions", collisions_total},
      {"collision_rate", production_time > 0 ? 2.0 * static_cast<double>(production_collisions) /
                                                   (n * production_time)
                                             : 0.0},
      {"contacts_per_step",
       sim.current_step() ? static_cast<double>(contacts) / sim.current_step() : 0.0},
      {"multi_contact_bodies", multi_bodies},
      {"multi_contact_clusters", clusters},
      {"solver_iterations_max", solver_iterations_max},
      {"solver_unconverged", solver_unconverged},
      {"solver_energy_change", solver_energy_change},
      {"narrow_phase_tests_per_step",
       sim.current_step() ? static_cast<double>(narrow_tests) / sim.current_step() : 0.0},
      {"neighbor_list_builds", sim.neighbor_list().builds},
      {"max_overlap", max_depth},
      {"energy_drift", drift},
      {"wall_seconds", wall},
      {"particle_steps_per_second", wall > 0 ? particle_steps / wall : 0.0},
      {"ns_per_particle_step", particle_steps > 0 ? 1e9 * wall / particle_steps : 0.0},
      {"ranks", comm.size()},
      {"grid", sim.domain().grid()},
      {"threads", omp_get_max_threads()},
      {"topology", topology.description},
      {"binding", binding},
      {"placement", placements},
      {"state_checksum", sim.state_checksum()},
  };
  nlohmann::json timers;
  for (int r = 0; r < static_cast<int>(Region::kCount); ++r)
    timers[region_name(static_cast<Region>(r))] = sim.timers().seconds(static_cast<Region>(r));
  summary["timers"] = timers;
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
      static_cast<double>(comm.size()) * std::max<long long>(1, sim.current_step());
  for (const char *name :
       {"agree", "migrate", "shadows", "degrees", "results", "observe", "kinetic_energy"}) {
    const auto it = comm.traffic().find(name);
    const TrafficCounter c = it == comm.traffic().end() ? TrafficCounter{} : it->second;
    const long long messages = comm.sum("summary", c.messages);
    const long long bytes = comm.sum("summary", c.bytes);
    traffic[name] = {{"messages_per_step", static_cast<double>(messages) / rank_steps},
                     {"bytes_per_step", static_cast<double>(bytes) / rank_steps}};
  }
  summary["communication_per_rank"] = traffic;
  if (!failure.empty()) summary["error"] = failure;
  if (frank) {
    frank->save((dir / "frank.json").string());
    summary["frank_samples"] = frank->samples();
  }
  if (root && angular.total > 0) {
    nlohmann::json a;
    a["bins"] = kAngularBins;
    a["description"] =
        "distribution of |cos theta| between axes and the director over production samples, "
        "normalised so that the isotropic distribution is 1 in every bin";
    a["normalised"] = angular.normalised();
    a["total"] = angular.total;
    std::ofstream out(dir / "angular.json");
    out << a.dump(1) << "\n";
  }
  if (root) {
    std::ofstream out(dir / "summary.json");
    out << summary.dump(2) << "\n";
  }

  if (!quiet) {
    fmt::print("\n{}", sim.timers().table(particle_steps));
    fmt::print("counters: {}\n", counters.report());
    auto pm = [](const Estimate &e) {
      return std::isfinite(e.error) ? fmt::format("{:.4f} +/- {:.4f}", e.mean, e.error)
                                    : fmt::format("{:.4f} (no error: too few samples)", e.mean);
    };
    fmt::print("\nresults over {} production samples ({:.4g} tau):\n", s_series.size(),
               production_time);
    fmt::print("  order parameter S        {}\n", pm(s_est));
    fmt::print("  pressure P*              {}\n", pm(p_est));
    fmt::print("  compressibility Z        {}\n", pm(z_est));
    fmt::print("  collision rate           {:.4g} per particle per tau\n",
               summary["collision_rate"].get<double>());
    fmt::print("  max overlap              {:.3g} D\n", max_depth);
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
  }
  if (!failure.empty()) throw PhysicsError(failure);
  return summary;
}

}  // namespace hardrod
