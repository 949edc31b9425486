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
  // 12 production samples: too short to judge, so not equilibrated, and no fit trusted.
  EXPECT_FALSE(out["equilibrated"].get<bool>());
  ASSERT_EQ(out["equilibration"]["runs"].size(), 2u);
  EXPECT_FALSE(out["equilibration"]["runs"][0]["reasons"].empty());
  for (const char *model : {"planar", "cubic", "background"})
    EXPECT_FALSE(out["frank_fits"][model]["trusted"].get<bool>()) << model;
  EXPECT_FALSE(analysis_trusted(out));
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

// A run directory holding only summary.json with these fields changed from a good run's.
std::string fake_run(const std::string &name, const nlohmann::json &changes) {
  nlohmann::json summary = {{"status", "completed"},
                            {"n", 768},
                            {"aspect_ratio", 5.0},
                            {"box", {20.0, 20.0, 20.0}},
                            {"steps_done", 3000},
                            {"order_parameter", {{"mean", 0.8}, {"error", 0.01}, {"samples", 20}}},
                            {"pressure_star", {{"mean", 6.0}, {"error", 0.05}, {"samples", 20}}}};
  if (changes.is_object()) summary.update(changes);
  const fs::path dir = fs::temp_directory_path() / ("hardrod-analyze-fake-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "summary.json") << summary.dump(2);
  return dir.string();
}

std::string refusal(const std::vector<std::string> &dirs) {
  AnalyzeOptions options;
  options.plots = false;
  options.run_dirs = dirs;
  options.output_dir = (fs::temp_directory_path() / "hardrod-analyze-fake-out").string();
  try {
    analyze_runs(options);
  } catch (const std::runtime_error &e) {
    return e.what();
  }
  return "";
}

// A failed run, a run without production samples and runs of different systems have nothing
// to merge: each is refused with a message that names the run and why.
TEST(Analyze, RefusesRunsWithoutResultsAndOfDifferentSystems) {
  const std::string good = fake_run("good", {});
  EXPECT_EQ(refusal({good}), "");
  const std::string failed =
      fake_run("failed", {{"status", "failed"}, {"error", "step 1: overlap 0.3 D"}});
  EXPECT_NE(refusal({failed}).find("the run failed (\"step 1: overlap 0.3 D\")"), std::string::npos)
      << refusal({failed});
  const std::string empty = fake_run(
      "empty", {{"order_parameter", {{"mean", nullptr}, {"error", nullptr}, {"samples", 0}}}});
  EXPECT_NE(refusal({empty}).find("no production samples"), std::string::npos);
  const std::string other = fake_run("other", {{"n", 2304}});
  const std::string mixed = refusal({good, other});
  EXPECT_NE(mixed.find("n = 768"), std::string::npos) << mixed;
  EXPECT_NE(mixed.find("n = 2304"), std::string::npos) << mixed;
  EXPECT_NE(mixed.find("different systems"), std::string::npos) << mixed;
}

}  // namespace
}  // namespace hardrod
