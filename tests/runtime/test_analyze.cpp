// `hardrod analyze` on real (short) runs: the public keys of analysis.json, merging two
// seeds, and clear errors for missing or mixed inputs.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "runtime/analyze.hpp"
#include "runtime/run.hpp"
#include "tests/test_scenes.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

std::string short_frank_run(unsigned long long seed, bool frank) {
  Scene scene = testing::small_nematic(2e-4);
  scene.seed = seed;
  scene.equilibration_steps = 200;
  scene.steps = 1200;
  scene.sample_interval = 100;
  scene.thermostat_interval = 200;
  scene.frank = frank;
  scene.fourier_kmax = 3;
  scene.fourier_interval = 50;
  const fs::path dir =
      fs::temp_directory_path() / ("hardrod-analyze-" + std::to_string(seed) + (frank ? "f" : "n"));
  fs::remove_all(dir);
  RunOptions options;
  options.output_dir = dir.string();
  options.quiet = true;
  run_scene(scene, options);
  return dir.string();
}

TEST(Analyze, MergesRunsIntoThePublicKeys) {
  const std::string a = short_frank_run(1, true), b = short_frank_run(2, true);
  ASSERT_TRUE(fs::exists(fs::path(a) / "frank.json"));
  ASSERT_TRUE(fs::exists(fs::path(a) / "angular.json"));
  AnalyzeOptions options;
  options.run_dirs = {a, b};
  options.output_dir = (fs::temp_directory_path() / "hardrod-analyze-out").string();
  options.plots = false;
  const auto out = analyze_runs(options);
  EXPECT_EQ(out["runs"].get<int>(), 2);
  for (const char *k : {"K1", "K2", "K3"})
    for (const char *model : {"planar", "cubic"}) {
      ASSERT_TRUE(out[k][model].contains("mean")) << k << " " << model;
      ASSERT_TRUE(out[k][model].contains("error")) << k << " " << model;
    }
  EXPECT_EQ(out["fourier_samples"].get<long long>(), 2 * 1200 / 50);
  EXPECT_GT(out["order_parameter"]["mean"].get<double>(), 0.5);
  EXPECT_TRUE(out["pressure_star"]["error"].is_number());
  EXPECT_TRUE(fs::exists(fs::path(options.output_dir) / "analysis.json"));
}

TEST(Analyze, RefusesMixedRunsAndMissingFiles) {
  const std::string with = short_frank_run(3, true), without = short_frank_run(4, false);
  EXPECT_FALSE(fs::exists(fs::path(without) / "frank.json"));  // not paid for unless asked
  AnalyzeOptions options;
  options.plots = false;
  options.run_dirs = {with, without};
  EXPECT_THROW(analyze_runs(options), std::runtime_error);
  options.run_dirs = {"/nonexistent/run"};
  try {
    analyze_runs(options);
    FAIL() << "a missing run directory must be an error";
  } catch (const std::runtime_error &e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/run/summary.json"), std::string::npos);
  }
}

}  // namespace
}  // namespace hardrod
