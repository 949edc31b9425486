// RunState's interval sums and its checkpoint JSON (see run_state.hpp).
#include "runtime/run_state.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <stdexcept>

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
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE_WITH_DEFAULT(RunState, s_series, p_series, z_series, collisions,
                                                production_collisions, narrow_tests, contacts,
                                                multi_bodies, clusters, solver_iterations_max,
                                                solver_unconverged, max_depth, solver_energy_change,
                                                running_sum, running_count, kinetic_start, angular,
                                                wall_seconds, setup_seconds, segments, list_builds,
                                                timeseries_bytes, trajectory_frames)
NLOHMANN_DEFINE_TYPE_NON_INTRUSIVE(SavedState, run, interval, thermostat)

namespace {

// The keys without which a resumed run would not end with the uninterrupted run's numbers.
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

}  // namespace

void RunState::add_interval(const IntervalTotals &t, bool production) {
  collisions += t.collisions;
  narrow_tests += t.narrow_phase_tests;
  contacts += t.contacts;
  multi_bodies += t.multi_contact_bodies;
  clusters += t.clusters;
  solver_iterations_max = std::max(solver_iterations_max, t.solver_iterations_max);
  solver_unconverged += t.solver_unconverged;
  solver_energy_change += t.solver_energy_change;
  max_depth = std::max(max_depth, t.max_depth);
  if (production) production_collisions += t.collisions;
}

std::string saved_state_json(const SavedState &state) { return nlohmann::json(state).dump(); }

SavedState parse_saved_state(const std::string &json_text) {
  const auto state = nlohmann::json::parse(json_text);
  for (const char *key : kRequiredRunKeys)
    if (!state.at("run").contains(key))
      throw std::invalid_argument(fmt::format("run.{} is missing", key));
  SavedState saved = state.get<SavedState>();
  if (static_cast<int>(saved.run.angular.counts.size()) != kAngularBins)
    throw std::invalid_argument("angular_counts has the wrong number of bins");
  return saved;
}

}  // namespace hardrod
