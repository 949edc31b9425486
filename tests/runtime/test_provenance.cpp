// Provenance (runtime/provenance.hpp): the command line as a shell reads it back, the start
// time in ISO 8601 UTC, and a run's summary.json and scene.toml saying what was run, how and
// where (the output directory the run used, not the scene's).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "runtime/provenance.hpp"
#include "runtime/run.hpp"
#include "tests/test_scenes.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

TEST(Provenance, ShellQuoteKeepsPlainWordsAndQuotesTheRest) {
  EXPECT_EQ(shell_quote("run.dt=1e-4"), "run.dt=1e-4");
  EXPECT_EQ(shell_quote("runs/x"), "runs/x");
  EXPECT_EQ(shell_quote("init.lattice=[4, 24, 24]"), "'init.lattice=[4, 24, 24]'");
  EXPECT_EQ(shell_quote("it's"), "'it'\\''s'");
  EXPECT_EQ(shell_quote(""), "''");
}

TEST(Provenance, TimesAreIso8601Utc) {
  EXPECT_EQ(iso8601_utc(0), "1970-01-01T00:00:00Z");
  EXPECT_EQ(iso8601_utc(1795609496), "2026-11-25T12:24:56Z");
}

TEST(Provenance, RecordsTheCommandLineTheBuildAndTheHost) {
  const char *argv[] = {"hardrod", "run", "scene.toml", "--set", "init.lattice=[2, 12, 12]"};
  record_command_line(5, argv);
  const Provenance &p = process_provenance();
  EXPECT_EQ(p.command_line, "hardrod run scene.toml --set 'init.lattice=[2, 12, 12]'");
  EXPECT_TRUE(std::regex_match(p.started_at, std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ)")))
      << p.started_at;
  EXPECT_EQ(p.version, HARDROD_TEST_VERSION);
  EXPECT_FALSE(p.git_commit.empty());
  EXPECT_FALSE(p.host.empty());
  const nlohmann::json j = provenance_json(p);
  for (const char *key : {"version", "git_commit", "command_line", "started_at", "host"})
    EXPECT_TRUE(j.contains(key)) << key;
}

// A run sent elsewhere with --out: summary.json carries the provenance, and scene.toml (and
// so a rerun from it) names the directory the run wrote, not the scene's output.dir.
TEST(Provenance, SummaryAndSceneCopySayWhatRanAndWhere) {
  const fs::path dir = fs::temp_directory_path() / "hardrod-test-provenance-run";
  fs::remove_all(dir);
  Scene scene = testing::small_nematic(1e-3);
  scene.steps = 100;
  scene.sample_interval = 50;
  scene.output_dir = "runs/the-scene-said-here";
  RunOptions options;
  options.output_dir = dir.string();
  options.quiet = true;
  options.bind = false;
  const nlohmann::json summary = run_scene(scene, options);
  for (const char *key : {"version", "git_commit", "command_line", "started_at", "host"})
    EXPECT_TRUE(summary.contains(key) && summary[key].is_string()) << key;
  std::ifstream in(dir / "summary.json");
  const nlohmann::json written = nlohmann::json::parse(in);
  EXPECT_EQ(written["git_commit"], summary["git_commit"]);
  EXPECT_EQ(written["started_at"], process_provenance().started_at);
  std::stringstream toml;
  toml << std::ifstream(dir / "scene.toml").rdbuf();
  EXPECT_EQ(parse_scene(toml.str()).output_dir, dir.string()) << toml.str();
  EXPECT_FALSE(fs::exists("runs/the-scene-said-here"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hardrod
