// The run's printed header, progress line, summary.json and final report (see
// run_report.hpp). The order of the collective calls here is the same on every rank.
#include "runtime/run_report.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "perf/region_timer.hpp"
#include "perf/simulated_compute.hpp"
#include "perf/topology.hpp"
#include "runtime/provenance.hpp"
#include "runtime/step_method.hpp"

namespace hardrod {

namespace fs = std::filesystem;

std::string duration_text(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  const auto s = static_cast<long long>(seconds + 0.5);
  if (s >= 3600) return fmt::format("{}h{:02}m", s / 3600, (s / 60) % 60);
  if (s >= 60) return fmt::format("{}m{:02}s", s / 60, s % 60);
  return fmt::format("{}s", s);
}

// No samples, no result: null, never a 0 that reads like a measurement.
nlohmann::json estimate_json(const Estimate &e) {
  return {{"mean", e.samples > 0 ? nlohmann::json(e.mean) : nlohmann::json(nullptr)},
          {"error", std::isfinite(e.error) ? nlohmann::json(e.error) : nlohmann::json(nullptr)},
          {"samples", e.samples},
          {"converged", e.converged}};
}

Placement place_threads(Communicator &comm, bool bind) {
  Placement p;
  p.binding = bind_threads(bind);
  const std::string mine = fmt::format("rank {}: {}", comm.rank(), thread_placement());
  const std::vector<char> all = comm.gather("setup", std::vector<char>(mine.begin(), mine.end()));
  // Rank lines are gathered as one block; split them at the "rank " prefixes.
  const std::string text(all.begin(), all.end());
  for (std::size_t pos = 0; pos < text.size();) {
    const std::size_t next = text.find("rank ", pos + 1);
    p.ranks.push_back(text.substr(pos, next == std::string::npos ? next : next - pos));
    pos = next == std::string::npos ? text.size() : next;
  }
  p.topology = describe_topology().description;
  return p;
}

void print_run_header(const Scene &scene, System &sim, const fs::path &dir, const Checkpoint *from,
                      const Placement &placement) {
  fmt::print(
      "hardrod: {} (L/D = {:g}), N = {}, rho* = {:.4f}, eta = {:.4f}, box {:.4f} x "
      "{:.4f} x {:.4f}\n",
      scene.shape.is_sphere() ? "hard spheres" : "hard spherocylinders", scene.shape.length,
      scene.n, scene.reduced_density(), scene.packing_fraction(), scene.box.length.x,
      scene.box.length.y, scene.box.length.z);
  fmt::print(
      "hardrod: dt = {:g}, {} equilibration + {} production steps, {} rank(s) x {} thread(s), "
      "output {}\n",
      scene.dt, scene.equilibration_steps, scene.steps, sim.comm().size(), omp_get_max_threads(),
      dir.string());
  if (from)
    fmt::print("hardrod: resumed from the checkpoint at step {} (state checksum {})\n", from->step,
               from->state_checksum);
  if (sim.comm().size() > 1) fmt::print("hardrod: {}\n", sim.domain().describe());
  fmt::print("hardrod: machine {}; {}\n", placement.topology, placement.binding);
  for (const auto &p : placement.ranks) fmt::print("hardrod:   {}\n", p);
  std::fflush(stdout);
}

std::string progress_line(const Progress &p) {
  const double rate = p.elapsed > 0 ? static_cast<double>(p.step - p.first_step) / p.elapsed : 0.0;
  const double eta_s = rate > 0 ? static_cast<double>(p.total_steps - p.step) / rate : 0.0;
  return fmt::format(
      "step {:>{}}/{} {:<5} t = {:.4g} tau  {:.3g} steps/s  ETA {:<7} S = {}  P* = {}", p.step,
      std::to_string(p.total_steps).size(), p.total_steps,
      p.step <= p.equilibration_steps ? "equil" : "prod", p.time, rate, duration_text(eta_s),
      p.order_parameter ? fmt::format("{:.4f}", *p.order_parameter) : "-",
      p.running_pressure ? fmt::format("{:.4f}", *p.running_pressure) : "-");
}

namespace {

// Energy drift: relative kinetic-energy change per tau that the thermostat had to undo,
// or, with the thermostat off, the change over the whole run (collective then).
double energy_drift(const Scene &scene, System &sim, const RunState &st) {
  const ThermostatRecord &thermostat = sim.thermostat_record();
  const double simulated = sim.time();
  if (thermostat.applications > 0)
    return thermostat.correction_sum / (static_cast<double>(thermostat.applications) *
                                        static_cast<double>(scene.thermostat_interval) * scene.dt);
  if (simulated > 0) return (sim.kinetic_energy() / st.kinetic_start - 1.0) / simulated;
  return 0.0;
}

// Region timers: rank 0's, and over all ranks the slowest and the mean (load balance); the
// same per production step (this segment's), which leaves out the set-up and the warm-up.
void add_timers(nlohmann::json &summary, System &sim, const RunOutcome &outcome) {
  Communicator &comm = sim.comm();
  const auto nregions = static_cast<std::size_t>(Region::kCount);
  const double steps = static_cast<double>(std::max<long long>(1, outcome.production_steps));
  std::vector<double> mine(2 * nregions);
  std::vector<ExactSum> total(2 * nregions);
  for (std::size_t r = 0; r < nregions; ++r) {
    const auto region = static_cast<Region>(r);
    mine[r] = sim.timers().seconds(region);
    mine[nregions + r] = outcome.production_steps > 0
                             ? (mine[r] - outcome.timers_before_production.seconds(region)) / steps
                             : 0.0;
    total[r].add(mine[r]);
    total[nregions + r].add(mine[nregions + r]);
  }
  const std::vector<double> slowest = comm.max("summary", mine);
  total = comm.sum("summary", total);
  nlohmann::json timers, most, mean, production_most, production_mean;
  for (std::size_t r = 0; r < nregions; ++r) {
    const char *name = region_name(static_cast<Region>(r));
    timers[name] = mine[r];
    most[name] = slowest[r];
    mean[name] = total[r].value() / comm.size();
    production_most[name] = slowest[nregions + r];
    production_mean[name] = total[nregions + r].value() / comm.size();
  }
  summary["timers"] = timers;
  summary["timers_rank_max"] = most;
  summary["timers_rank_mean"] = mean;
  summary["production_timers_per_step"] = {{"rank_mean", production_mean},
                                           {"rank_max", production_most}};
}

// Communication per step per rank, averaged over ranks, by communication step: messages, bytes
// and the time in the calls (waiting for the other ranks included).
// Per rank and step, over this segment's steps; the seconds also over its production steps.
nlohmann::json traffic_json(Communicator &comm, long long steps, const RunOutcome &outcome) {
  nlohmann::json traffic = nlohmann::json::object();
  const auto per_rank_step = [&](long long n) {
    return static_cast<double>(comm.size()) * static_cast<double>(std::max<long long>(1, n));
  };
  for (const char *name :
       {"agree", "migrate", "shadows", "contacts", "results", "exact_pieces", "exact_results",
        "exact_round", "observe", "kinetic_energy", "checkpoint", "balance", "burst"}) {
    const auto it = comm.traffic().find(name);
    const TrafficCounter c = it == comm.traffic().end() ? TrafficCounter{} : it->second;
    const auto before = outcome.traffic_seconds_before_production.find(name);
    const long long messages = comm.sum("summary", c.messages);
    const long long bytes = comm.sum("summary", c.bytes);
    std::vector<ExactSum> seconds(2);
    seconds[0].add(c.seconds);
    seconds[1].add(outcome.production_steps == 0 ? 0.0
                   : before == outcome.traffic_seconds_before_production.end()
                       ? c.seconds
                       : c.seconds - before->second);
    seconds = comm.sum("summary", seconds);
    traffic[name] = {{"messages_per_step", static_cast<double>(messages) / per_rank_step(steps)},
                     {"bytes_per_step", static_cast<double>(bytes) / per_rank_step(steps)},
                     {"seconds_per_step", seconds[0].value() / per_rank_step(steps)},
                     {"production_seconds_per_step",
                      seconds[1].value() / per_rank_step(outcome.production_steps)}};
  }
  return traffic;
}

// The ranks' computation in the production steps: a step's time less the communication
// inside it, mean and slowest rank, per step; their ratio is the load imbalance.
nlohmann::json production_compute_json(Communicator &comm, const RunOutcome &outcome) {
  double inside = 0.0;
  for (const char *name : {"agree", "migrate", "shadows", "contacts", "results", "exact_pieces",
                           "exact_results", "exact_round", "kinetic_energy", "balance"}) {
    const auto it = comm.traffic().find(name);
    if (it == comm.traffic().end()) continue;
    const auto before = outcome.traffic_seconds_before_production.find(name);
    inside += it->second.seconds -
              (before == outcome.traffic_seconds_before_production.end() ? 0.0 : before->second);
  }
  const double steps = static_cast<double>(std::max<long long>(1, outcome.production_steps));
  const double here =
      outcome.production_steps > 0 ? (outcome.production_step_seconds_here - inside) / steps : 0.0;
  ExactSum sum;
  sum.add(here);
  sum = comm.sum("summary", sum);
  const double most = comm.max("summary", {here})[0];
  return {{"rank_mean", sum.value() / comm.size()}, {"rank_max", most}};
}

// Under SMPI, when the program charged its own computation: what all ranks charged, and what
// the noise filter took off.
nlohmann::json simulated_compute_json(Communicator &comm) {
  const simulated::ComputeTotals t = simulated::totals();
  ExactSum charged, clipped;
  charged.add(t.charged_seconds);
  clipped.add(t.clipped_seconds);
  charged = comm.sum("summary", charged);
  clipped = comm.sum("summary", clipped);
  const std::vector<double> extremes = comm.max("summary", {t.charged_seconds, -t.charged_seconds});
  return {{"stretches", comm.sum("summary", t.stretches)},
          {"charged_seconds_rank_max", extremes[0]},
          {"charged_seconds_rank_min", -extremes[1]},
          {"clipped", comm.sum("summary", t.clipped)},
          {"charged_seconds", charged.value()},
          {"clipped_seconds", clipped.value()}};
}

// Rank 0's threads' hardware counters, or why there are none.
nlohmann::json counters_json(const HardwareCounters &counters) {
  nlohmann::json hw;
  hw["available"] = counters.available();
  if (counters.available())
    for (const auto &[name, value] : counters.values()) hw[name] = value;
  else
    hw["reason"] = counters.reason();
  return hw;
}

nlohmann::json balance_json(System &sim) {
  const BalanceRecord &b = sim.balance_record();
  return {{"mode", balance_mode_name(sim.balance_options().mode)},
          {"interval", sim.balance_options().interval},
          {"threshold", sim.balance_options().threshold},
          {"checks", b.checks},
          {"shifts", b.shifts},
          {"forced_rebuilds", b.forced_rebuilds},
          {"first_imbalance", b.first_imbalance},
          {"last_imbalance", b.last_imbalance},
          {"max_imbalance", b.max_imbalance},
          {"largest_shift", b.largest_shift},
          {"partner_reach", sim.domain().partner_reach()},
          {"cuts", sim.domain().cuts()}};
}

// The system and the run's length.
nlohmann::json scene_json(const Scene &scene, const System &sim, long long steps_done,
                          double production_time) {
  return {{"shape", scene.shape_name},
          {"n", scene.n},
          {"aspect_ratio", scene.shape.length},
          {"box", {scene.box.length.x, scene.box.length.y, scene.box.length.z}},
          {"reduced_density", scene.reduced_density()},
          {"packing_fraction", scene.packing_fraction()},
          {"dt", scene.dt},
          {"seed", scene.seed},
          {"equilibration_steps", scene.equilibration_steps},
          {"steps", scene.steps},
          {"steps_done", steps_done},
          {"simulated_time", sim.time()},
          {"production_time", production_time},
          {"method", scene.method == kExact ? "exact" : "midpoint"}};
}

// The observables, and the work of the steps that gave them.
nlohmann::json results_json(const Scene &scene, System &sim, const RunState &st,
                            long long steps_done, double production_time, double drift) {
  const double n = static_cast<double>(scene.n);
  const auto per_step = [&](long long count) {
    return steps_done ? static_cast<double>(count) / steps_done : 0.0;
  };
  const EquilibrationCheck s_eq = check_equilibration(st.s_series);
  const EquilibrationCheck p_eq = check_equilibration(st.p_series);
  return {
      {"pressure_star", estimate_json(block_average(st.p_series))},
      {"order_parameter", estimate_json(block_average(st.s_series))},
      {"compressibility_factor", estimate_json(block_average(st.z_series))},
      {"equilibrated", s_eq.equilibrated && p_eq.equilibrated},
      {"collisions", st.collisions},
      {"collision_rate", production_time > 0 ? 2.0 * static_cast<double>(st.production_collisions) /
                                                   (n * production_time)
                                             : 0.0},
      {"contacts_per_step", per_step(st.contacts)},
      {"multi_contact_bodies", st.multi_bodies},
      {"multi_contact_clusters", st.clusters},
      {"solver_iterations_max", st.solver_iterations_max},
      {"solver_unconverged", st.solver_unconverged},
      {"solver_energy_change", st.solver_energy_change.value()},
      {"narrow_phase_tests_per_step", per_step(st.narrow_tests)},
      {"neighbor_list_builds", st.list_builds + sim.neighbor_list().builds},
      {"max_overlap", st.max_depth},
      {"energy_drift", drift},
  };
}

// What the run cost and where it ran.
nlohmann::json cost_json(const Scene &scene, System &sim, const RunState &st,
                         const RunOutcome &outcome, const Placement &placement,
                         long long steps_done) {
  const double particle_steps =
      static_cast<double>(scene.n) * static_cast<double>(steps_done - outcome.first_step);
  const double wall = outcome.wall_seconds;
  return {
      {"wall_seconds", wall},
      {"step_seconds", outcome.step_seconds},
      {"seconds_per_step",
       steps_done > outcome.first_step
           ? outcome.step_seconds / static_cast<double>(steps_done - outcome.first_step)
           : 0.0},
      {"production_seconds_per_step", outcome.production_seconds_per_step},
      {"setup_seconds", outcome.setup_seconds},
      {"setup_seconds_total", st.setup_seconds + outcome.setup_seconds},
      {"wall_seconds_total", st.wall_seconds + wall},
      {"segments", st.segments + 1},
      {"first_step", outcome.first_step},
      {"particle_steps_per_second", wall > 0 ? particle_steps / wall : 0.0},
      {"ns_per_particle_step", particle_steps > 0 ? 1e9 * wall / particle_steps : 0.0},
      {"ranks", sim.comm().size()},
      {"grid", sim.domain().grid()},
      {"balance", balance_json(sim)},
      {"threads", omp_get_max_threads()},
      {"topology", placement.topology},
      {"binding", placement.binding},
      {"placement", placement.ranks},
  };
}

}  // namespace

// The parts that reduce over ranks come in the same order on every rank: the energy drift, the
// checksum, provenance, the timers, the watched share, the method's part and the traffic.
nlohmann::json run_summary(const Scene &scene, System &sim, const RunState &st,
                           const RunOutcome &outcome, const Placement &placement,
                           const HardwareCounters &counters) {
  Communicator &comm = sim.comm();
  const long long steps_done = sim.current_step();
  const double production_time =
      static_cast<double>(std::max<long long>(0, steps_done - scene.equilibration_steps)) *
      scene.dt;
  const double drift = energy_drift(scene, sim, st);
  nlohmann::json summary = scene_json(scene, sim, steps_done, production_time);
  summary["status"] = !outcome.failure.empty()      ? "failed"
                      : !outcome.stopped_by.empty() ? "interrupted"
                                                    : "completed";
  summary.update(results_json(scene, sim, st, steps_done, production_time, drift));
  summary.update(cost_json(scene, sim, st, outcome, placement, steps_done));
  summary["state_checksum"] = sim.state_checksum();
  summary.update(provenance_json(agreed_provenance(comm)));
  add_timers(summary, sim, outcome);
  {  // the shares of detections that went through the watches, or the near pairs, over all ranks
    const long long all = comm.sum("summary", sim.detections());
    const long long watched = comm.sum("summary", sim.detections_watched());
    const long long near = comm.sum("summary", sim.detections_near());
    summary["detect_watched_share"] = all > 0 ? static_cast<double>(watched) / all : 0.0;
    summary["detect_near_share"] = all > 0 ? static_cast<double>(near) / all : 0.0;
  }
  sim.method().summarize(comm, summary);
  summary["hardware_counters"] = counters_json(counters);
  summary["communication_per_rank"] = traffic_json(comm, steps_done - outcome.first_step, outcome);
  summary["production_compute_seconds_per_step"] = production_compute_json(comm, outcome);
  if (simulated::charging()) summary["simulated_compute"] = simulated_compute_json(comm);
  if (!outcome.failure.empty()) summary["error"] = outcome.failure;
  if (!outcome.stopped_by.empty()) summary["stopped_by"] = outcome.stopped_by;
  return summary;
}

namespace {

// The physics: what the run measured, with errors; a failed run says so first.
void print_results(const StepMethod &method, const RunState &st, const nlohmann::json &summary,
                   const fs::path &dir) {
  if (summary["status"] == "failed")
    fmt::print("\nFAILED: {}\n", summary.value("error", std::string("(no message)")));
  auto pm = [](const Estimate &e) {
    if (e.samples == 0) return std::string("none (no production samples)");
    return std::isfinite(e.error) ? fmt::format("{:.4f} +/- {:.4f}", e.mean, e.error)
                                  : fmt::format("{:.4f} (no error: too few samples)", e.mean);
  };
  fmt::print("\nresults over {} production samples ({:.4g} tau):\n", st.s_series.size(),
             summary["production_time"].get<double>());
  fmt::print("  order parameter S        {}\n", pm(block_average(st.s_series)));
  fmt::print("  pressure P*              {}\n", pm(block_average(st.p_series)));
  fmt::print("  compressibility Z        {}\n", pm(block_average(st.z_series)));
  fmt::print("  collision rate           {:.4g} per particle per tau\n",
             summary["collision_rate"].get<double>());
  fmt::print("  max overlap              {:.3g} D\n", st.max_depth);
  fmt::print("  energy drift             {:.3g} per tau\n", summary["energy_drift"].get<double>());
  fmt::print("  equilibrated             {}\n",
             summary["equilibrated"].get<bool>()
                 ? "yes"
                 : "not sure (first and last third of production differ)");
  method.print_results(summary);
  fmt::print("  speed                    {:.1f} ns per particle-step, {:.3g} particle-steps/s\n",
             summary["ns_per_particle_step"].get<double>(),
             summary["particle_steps_per_second"].get<double>());
  fmt::print("  state checksum           {}\n", summary["state_checksum"].get<std::string>());
  fmt::print("  summary                  {}\n", (dir / "summary.json").string());
}

// The parallel bookkeeping of a run on several ranks: load balance, clusters across ranks.
void print_parallel(System &sim, const nlohmann::json &summary) {
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
  sim.method().print_parallel(summary);
}

}  // namespace

// The physics first (what the user ran for), then where the time went.
void print_run_report(System &sim, const RunState &st, const nlohmann::json &summary,
                      const HardwareCounters &counters, const fs::path &dir) {
  print_results(sim.method(), st, summary, dir);
  const double particle_steps = static_cast<double>(summary["n"].get<long long>()) *
                                static_cast<double>(summary["steps_done"].get<long long>() -
                                                    summary["first_step"].get<long long>());
  fmt::print("\n{}", sim.timers().table(particle_steps));
  fmt::print("counters: {}\n", counters.report());
  if (sim.comm().size() > 1) print_parallel(sim, summary);
  std::fflush(stdout);
}

}  // namespace hardrod
