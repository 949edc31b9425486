// The run's printed text and summary fragments that do not need a simulation: durations,
// estimates with and without an error, the progress line.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "runtime/run_report.hpp"

namespace hardrod {
namespace {

TEST(RunReport, DurationText) {
  EXPECT_EQ(duration_text(42.4), "42s");
  EXPECT_EQ(duration_text(187), "3m07s");
  EXPECT_EQ(duration_text(7500), "2h05m");
  EXPECT_EQ(duration_text(-1), "?");
  EXPECT_EQ(duration_text(std::nan("")), "?");
}

// A run without production samples has no S or P*: null, not a 0 that reads like a result.
TEST(RunReport, EstimateWithoutSamplesIsNull) {
  const auto j = estimate_json(block_average({}));
  EXPECT_TRUE(j["mean"].is_null()) << j.dump();
  EXPECT_TRUE(j["error"].is_null()) << j.dump();
  EXPECT_EQ(j["samples"].get<long long>(), 0);
}

TEST(RunReport, EstimateWithoutErrorIsNull) {
  Estimate e;
  e.mean = 1.5;
  e.error = std::numeric_limits<double>::infinity();
  e.samples = 3;
  const auto j = estimate_json(e);
  EXPECT_EQ(j["mean"].get<double>(), 1.5);
  EXPECT_TRUE(j["error"].is_null());
  EXPECT_EQ(j["samples"].get<long long>(), 3);
}

TEST(RunReport, ProgressLine) {
  Progress p;
  p.step = 500;
  p.first_step = 0;
  p.total_steps = 2000;
  p.equilibration_steps = 1000;
  p.time = 0.5;
  p.elapsed = 5.0;
  EXPECT_EQ(progress_line(p),
            "step  500/2000 equil t = 0.5 tau  100 steps/s  ETA 15s     S = -  P* = -");
  p.step = 1500;
  p.order_parameter = 0.25;
  p.running_pressure = 3.0;
  EXPECT_EQ(progress_line(p),
            "step 1500/2000 prod  t = 0.5 tau  300 steps/s  ETA 2s      S = 0.2500  P* = 3.0000");
}

}  // namespace
}  // namespace hardrod
