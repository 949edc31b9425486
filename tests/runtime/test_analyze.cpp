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

std::string short_frank_run(unsigned long long seed, bool frank, int kmax = 3) {
  Scene scene = testing::small_nematic(2e-4);
  scene.seed = seed;
  scene.equilibration_steps = 200;
  scene.steps = 1200;
  scene.sample_interval = 100;
  scene.thermostat_interval = 200;
  scene.frank = frank;
  scene.fourier_kmax = kmax;
  scene.fourier_interval = 50;
  const fs::path dir = fs::temp_directory_path() / ("hardrod-analyze-" + std::to_string(seed) +
                                                    (frank ? "f" : "n") + std::to_string(kmax));
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

std::string refusal(const std::vector<std::string> &dirs, bool allow_mixed = false,
                    const std::string &out = "hardrod-analyze-fake-out") {
  AnalyzeOptions options;
  options.plots = false;
  options.run_dirs = dirs;
  options.allow_mixed = allow_mixed;
  options.output_dir = (fs::temp_directory_path() / out).string();
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

// Copies of one run (same seed, or same final state) are one sample, not two; runs of
// different dt, method or Fourier kmax are different protocols unless the user allows it.
TEST(Analyze, RefusesCopiesAndMixedProtocols) {
  const nlohmann::json base = {
      {"seed", 1}, {"dt", 1e-4}, {"method", "midpoint"}, {"state_checksum", "0a"}};
  const auto with = [&](const nlohmann::json &changes) {
    nlohmann::json j = base;
    j.update(changes);
    return j;
  };
  const std::string a = fake_run("proto-a", base);
  const std::string copy = fake_run("proto-copy", base);
  EXPECT_NE(refusal({a, copy}).find("the same seed (1)"), std::string::npos) << refusal({a, copy});
  const std::string same_state = fake_run("proto-state", with({{"seed", 2}}));
  EXPECT_NE(refusal({a, same_state}).find("the same state_checksum"), std::string::npos);
  const std::string b = fake_run("proto-b", with({{"seed", 2}, {"state_checksum", "0b"}}));
  EXPECT_EQ(refusal({a, b}), "");
  const std::string dt =
      fake_run("proto-dt", with({{"seed", 3}, {"state_checksum", "0c"}, {"dt", 2e-4}}));
  const std::string mixed = refusal({a, dt});
  EXPECT_NE(mixed.find("run.dt 0.0001 against 0.0002"), std::string::npos) << mixed;
  EXPECT_NE(mixed.find("--allow-mixed"), std::string::npos) << mixed;
  EXPECT_EQ(refusal({a, dt}, true), "");
  const std::string exact =
      fake_run("proto-exact", with({{"seed", 4}, {"state_checksum", "0d"}, {"method", "exact"}}));
  EXPECT_NE(refusal({a, exact}).find("run.method"), std::string::npos);
  // Fourier modes to another kmax: a different estimator of the same K.
  const std::string k3 = short_frank_run(5, true, 3), k4 = short_frank_run(6, true, 4);
  const std::string kmax = refusal({k3, k4});
  EXPECT_NE(kmax.find("observables.fourier_kmax (3 against 4)"), std::string::npos) << kmax;
}

// analysis.json that cannot be written is an error naming the file, never "written".
TEST(Analyze, AFailedWriteIsAnError) {
  const std::string good = fake_run("write-good", {});
  const fs::path out = fs::temp_directory_path() / "hardrod-analyze-unwritable";
  fs::remove_all(out);
  fs::create_directories(out / "analysis.json.tmp");  // where the file would be written first
  const std::string why = refusal({good}, false, "hardrod-analyze-unwritable");
  EXPECT_NE(why.find("cannot write"), std::string::npos) << why;
  EXPECT_FALSE(fs::exists(out / "analysis.json"));
}

}  // namespace
}  // namespace hardrod
