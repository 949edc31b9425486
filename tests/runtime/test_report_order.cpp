// The report printed at the end of a run (runtime/run_report.hpp): the physics first, then
// where the time went (timers, counters); a failed run leads with FAILED and its reason.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "runtime/run.hpp"
#include "tests/test_scenes.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

std::string report_of(Scene scene, const std::string &name) {
  const fs::path dir = fs::temp_directory_path() / ("hardrod-test-report-" + name);
  fs::remove_all(dir);
  RunOptions options;
  options.output_dir = dir.string();
  options.bind = false;
  ::testing::internal::CaptureStdout();
  try {
    run_scene(scene, options);
  } catch (const PhysicsError &) {
  }
  const std::string out = ::testing::internal::GetCapturedStdout();
  fs::remove_all(dir);
  return out;
}

TEST(ReportOrder, ResultsComeBeforeTimersAndCounters) {
  Scene scene = testing::small_nematic(1e-3);
  scene.steps = 200;
  scene.sample_interval = 50;
  const std::string out = report_of(scene, "completed");
  const auto results = out.find("results over");
  const auto timers = out.find("region ");
  const auto counters = out.find("counters:");
  ASSERT_NE(results, std::string::npos) << out;
  ASSERT_NE(timers, std::string::npos) << out;
  ASSERT_NE(counters, std::string::npos) << out;
  EXPECT_LT(results, timers) << out;
  EXPECT_LT(timers, counters) << out;
  EXPECT_EQ(out.find("FAILED"), std::string::npos) << out;
}

TEST(ReportOrder, AFailedRunSaysFailedAndWhyFirst) {
  Scene scene = testing::small_nematic(2e-3);
  scene.steps = 2000;
  scene.max_overlap = 1e-9;  // the first contact overlaps more than this
  const std::string out = report_of(scene, "failed");
  const auto failed = out.find("FAILED: step ");
  ASSERT_NE(failed, std::string::npos) << out;
  EXPECT_NE(out.find("run.max_overlap", failed), std::string::npos) << out;
  EXPECT_LT(failed, out.find("results over")) << out;
}

}  // namespace
}  // namespace hardrod
