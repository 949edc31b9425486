// The checks before a resume (see resume.hpp).
#include "runtime/resume.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <map>
#include <sstream>

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

// The canonical scene as "section.key" -> value, without the keys a resume may change (and
// output.dir, which names where the run was started, not what it is).
std::map<std::string, std::string> identity_keys(const std::string &canonical_toml) {
  std::map<std::string, std::string> keys;
  std::istringstream in(canonical_toml);
  std::string line, section;
  while (std::getline(in, line)) {
    if (line.size() > 2 && line.front() == '[' && line.back() == ']') {
      section = line.substr(1, line.size() - 2);
      continue;
    }
    const auto equals = line.find(" = ");
    if (line.empty() || line.front() == '#' || equals == std::string::npos) continue;
    const std::string key = section + "." + line.substr(0, equals);
    if (key == "output.dir" || std::ranges::find(kResumableKeys, key) != kResumableKeys.end())
      continue;
    keys[key] = line.substr(equals + 3);
  }
  return keys;
}

// A checkpoint belongs to the run in `dir` when it stores the same scene as the directory's
// scene.toml in every key a resume may not change (the system, its start, the dynamics,
// the observables). Refuses one from another run before anything in `dir` changes.
void check_same_run(const fs::path &dir, const fs::path &checkpoint,
                    const std::string &scene_toml) {
  const fs::path scene_file = dir / "scene.toml";
  std::error_code ec;
  if (!fs::exists(scene_file, ec)) return;  // nothing to compare with
  std::string run_scene;
  try {
    run_scene = scene_to_toml(load_scene(scene_file.string()));
  } catch (const SceneError &e) {
    throw CheckpointError(
        fmt::format("{}: unreadable, so {} cannot be checked to belong to "
                    "this run: {}",
                    scene_file.string(), checkpoint.string(), e.what()));
  }
  const auto ours = identity_keys(run_scene);
  const auto theirs = identity_keys(scene_toml);
  std::vector<std::string> differences;
  for (const auto &[key, value] : ours) {
    const auto other = theirs.find(key);
    const std::string other_value = other == theirs.end() ? "(absent)" : other->second;
    if (other_value != value)
      differences.push_back(fmt::format("{} = {} in the checkpoint, {} in {}", key, other_value,
                                        value, scene_file.string()));
  }
  for (const auto &[key, value] : theirs)
    if (!ours.contains(key))
      differences.push_back(
          fmt::format("{} = {} in the checkpoint, absent in {}", key, value, scene_file.string()));
  if (!differences.empty())
    throw CheckpointError(fmt::format(
        "{}: belongs to another run ({}); refusing to resume {} from it (nothing was changed)",
        checkpoint.string(), fmt::join(differences, "; "), dir.string()));
}

}  // namespace

ResumePoint find_resume_point(const std::string &dir, const std::vector<std::string> &overrides,
                              const std::string &checkpoint_path) {
  check_overrides(overrides);
  fs::path path =
      checkpoint_path.empty() ? fs::path(dir) / kCheckpointFile : fs::path(checkpoint_path);
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw CheckpointError(fmt::format("{}: no such run directory", dir));
  std::string note;
  // A job killed between the checkpoint's two renames leaves only the previous one, which is
  // complete (sealed): continue from it, a checkpoint interval earlier.
  if (checkpoint_path.empty() && !fs::exists(path, ec) &&
      fs::exists(fs::path(dir) / kPreviousCheckpointFile, ec)) {
    note = fmt::format(
        "{} is missing (the job was probably killed while replacing it); resuming from the "
        "previous one, {}",
        path.string(), (fs::path(dir) / kPreviousCheckpointFile).string());
    path = fs::path(dir) / kPreviousCheckpointFile;
  }
  Checkpoint c = read_checkpoint(path);
  check_same_run(dir, path, c.scene_toml);
  Scene scene = parse_scene(c.scene_toml, overrides, path.string() + ":/scene");
  if (scene.n != c.n)
    throw CheckpointError(
        fmt::format("{}: the scene has n = {}, the bodies {}", path.string(), scene.n, c.n));
  const long long total = scene.equilibration_steps + scene.steps;
  if (total < c.step)
    throw SceneError({fmt::format(
        "run.steps = {}: the checkpoint is at step {} already (equilibration {} + production "
        "{} steps); raise run.steps to at least {}",
        scene.steps, c.step, scene.equilibration_steps, c.step - scene.equilibration_steps,
        c.step - scene.equilibration_steps)});
  return {std::move(c), std::move(scene), std::move(note)};
}

}  // namespace hardrod
