// The checks before a resume (see resume.hpp).
#include "runtime/resume.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <filesystem>

namespace hardrod {

namespace fs = std::filesystem;

namespace {

// Keys a resume may change: the step target and how often things are written.
const std::array<std::string, 4> kResumableKeys = {
    "run.steps", "output.checkpoint_interval", "output.snapshot_interval", "output.log_interval"};

void check_overrides(const std::vector<std::string> &overrides) {
  std::vector<std::string> problems;
  for (const auto &o : overrides) {
    const std::string key = o.substr(0, o.find('='));
    if (std::find(kResumableKeys.begin(), kResumableKeys.end(), key) == kResumableKeys.end())
      problems.push_back(fmt::format(
          "--set {}: cannot be changed on resume (the run continues exactly); resume may "
          "change run.steps, output.checkpoint_interval, output.snapshot_interval and "
          "output.log_interval",
          o));
  }
  if (!problems.empty()) throw SceneError(problems);
}

}  // namespace

ResumePoint find_resume_point(const std::string &dir, const std::vector<std::string> &overrides,
                              const std::string &checkpoint_path) {
  check_overrides(overrides);
  const fs::path path =
      checkpoint_path.empty() ? fs::path(dir) / kCheckpointFile : fs::path(checkpoint_path);
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw CheckpointError(fmt::format("{}: no such run directory", dir));
  if (checkpoint_path.empty() && !fs::exists(path, ec) &&
      fs::exists(fs::path(dir) / kPreviousCheckpointFile, ec))
    throw CheckpointError(fmt::format(
        "{}: missing (the job was probably killed while replacing it); the previous one is "
        "complete: hardrod resume {} --checkpoint {}",
        path.string(), dir, (fs::path(dir) / kPreviousCheckpointFile).string()));
  Checkpoint c = read_checkpoint(path);
  Scene scene = parse_scene(c.scene_toml, overrides, path.string() + ":/scene");
  if (scene.n != c.n)
    throw CheckpointError(
        fmt::format("{}: the scene has n = {}, the bodies {}", path.string(), scene.n, c.n));
  const long long total = scene.equilibration_steps + scene.steps;
  if (total < c.step)
    throw SceneError({fmt::format(
        "run.steps = {}: the checkpoint is at step {} already (equilibration {} + production "
        "{} steps); raise run.steps to at least {}",
        scene.steps, c.step, scene.equilibration_steps, scene.steps,
        c.step - scene.equilibration_steps)});
  return {std::move(c), std::move(scene)};
}

}  // namespace hardrod
