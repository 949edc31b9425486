// RunState: one interval's totals added, and the checkpoint's run_state JSON read back
// exactly (ExactSum bit for bit), with the physics keys required.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "runtime/run_state.hpp"

namespace hardrod {
namespace {

SavedState example_state() {
  SavedState s;
  s.run.s_series = {0.1, 0.2};
  s.run.p_series = {3.5, 3.25};
  s.run.z_series = {10.0, 9.5};
  s.run.collisions = 1234;
  s.run.max_depth = 1e-7;
  s.run.solver_energy_change.add(0.1);
  s.run.solver_energy_change.add(1e-17);
  s.run.angular.counts.assign(kAngularBins, 3);
  s.run.angular.total = 3 * kAngularBins;
  s.run.timeseries_bytes = 4567;
  s.run.trajectory_frames = 3;
  s.interval.steps = 17;
  s.interval.virial.add(-2.5e-3);
  s.thermostat.correction_sum = 1e-9;
  s.thermostat.applications = 4;
  return s;
}

TEST(RunState, AddIntervalSumsCountersAndKeepsMaxima) {
  RunState st;
  IntervalTotals t;
  t.collisions = 5;
  t.contacts = 7;
  t.solver_iterations_max = 3;
  t.max_depth = 0.25;
  st.add_interval(t, false);
  t.solver_iterations_max = 2;
  t.max_depth = 0.5;
  st.add_interval(t, true);
  EXPECT_EQ(st.collisions, 10);
  EXPECT_EQ(st.production_collisions, 5);
  EXPECT_EQ(st.contacts, 14);
  EXPECT_EQ(st.solver_iterations_max, 3);
  EXPECT_EQ(st.max_depth, 0.5);
}

TEST(RunState, JsonRoundTripIsExact) {
  const SavedState s = example_state();
  const SavedState back = parse_saved_state(saved_state_json(s));
  EXPECT_EQ(back.run.s_series, s.run.s_series);
  EXPECT_EQ(back.run.p_series, s.run.p_series);
  EXPECT_EQ(back.run.collisions, s.run.collisions);
  EXPECT_EQ(back.run.solver_energy_change.raw(), s.run.solver_energy_change.raw());
  EXPECT_EQ(back.run.angular.counts, s.run.angular.counts);
  EXPECT_EQ(back.run.timeseries_bytes, 4567);
  EXPECT_EQ(back.interval.steps, 17);
  EXPECT_EQ(back.interval.virial.raw(), s.interval.virial.raw());
  EXPECT_EQ(back.thermostat.correction_sum, 1e-9);
  EXPECT_EQ(back.thermostat.applications, 4);
}

TEST(RunState, BookkeepingKeysMayBeAbsentPhysicsKeysMayNot) {
  auto j = nlohmann::json::parse(saved_state_json(example_state()));
  j["run"].erase("setup_seconds");  // a checkpoint of an earlier build
  EXPECT_EQ(parse_saved_state(j.dump()).run.setup_seconds, 0.0);
  j["run"].erase("p_series");
  EXPECT_THROW(parse_saved_state(j.dump()), std::exception);
}

TEST(RunState, WrongNumberOfAngularBinsIsRejected) {
  SavedState s = example_state();
  s.run.angular.counts.assign(kAngularBins - 1, 0);
  EXPECT_THROW(parse_saved_state(saved_state_json(s)), std::invalid_argument);
}

}  // namespace
}  // namespace hardrod
