// The checks before a resume (see resume.hpp).
#include "runtime/resume.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "runtime/run_files.hpp"

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
    // init.isotropic_sweeps bounds the set-up, which is over: not what the run is.
    if (key == "output.dir" || key == "init.isotropic_sweeps" ||
        std::ranges::find(kResumableKeys, key) != kResumableKeys.end())
      continue;
    keys[key] = line.substr(equals + 3);
  }
  return keys;
}

// The keys in which two scenes differ, `theirs` being the checkpoint's and `ours` from `where`.
std::vector<std::string> differences(const std::map<std::string, std::string> &ours,
                                     const std::map<std::string, std::string> &theirs,
                                     const std::string &where) {
  std::vector<std::string> out;
  for (const auto &[key, value] : ours) {
    const auto other = theirs.find(key);
    const std::string other_value = other == theirs.end() ? "(absent)" : other->second;
    if (other_value != value)
      out.push_back(
          fmt::format("{} = {} in the checkpoint, {} in {}", key, other_value, value, where));
  }
  for (const auto &[key, value] : theirs)
    if (!ours.contains(key))
      out.push_back(fmt::format("{} = {} in the checkpoint, absent in {}", key, value, where));
  return out;
}

// What summary.json says of the run that wrote it, as identity keys (those it records).
std::map<std::string, std::string> summary_identity(const fs::path &summary_file,
                                                    const std::map<std::string, std::string> &of) {
  std::ifstream in(summary_file);
  const nlohmann::json s = nlohmann::json::parse(in, nullptr, false);
  if (s.is_discarded() || !s.is_object())
    throw CheckpointError(
        fmt::format("{}: unreadable, so the checkpoint cannot be checked to "
                    "belong to this run",
                    summary_file.string()));
  // Summary key -> scene key; values in the canonical scene's spelling, so they compare.
  const std::array<std::pair<const char *, const char *>, 5> kKeys = {
      {{"n", "system.n"},
       {"seed", "init.seed"},
       {"dt", "run.dt"},
       {"method", "run.method"},
       {"aspect_ratio", "system.aspect_ratio"}}};
  std::map<std::string, std::string> keys;
  for (const auto &[summary_key, scene_key] : kKeys) {
    if (!s.contains(summary_key) || !of.contains(scene_key)) continue;
    const nlohmann::json &v = s[summary_key];
    const std::string &theirs = of.at(scene_key);
    // Numbers compare as numbers (the scene writes 1e-3 where JSON has 0.001).
    if (v.is_number()) {
      double x = 0.0;
      try {
        x = std::stod(theirs);
      } catch (const std::exception &) {
        x = NAN;
      }
      keys[scene_key] = x == v.get<double>() ? theirs : v.dump();
    } else if (v.is_string()) {
      const std::string quoted = fmt::format("\"{}\"", v.get<std::string>());
      keys[scene_key] = quoted;
    }
  }
  return keys;
}

void refuse_other_run(const fs::path &dir, const fs::path &checkpoint,
                      const std::vector<std::string> &diffs) {
  if (diffs.empty()) return;
  throw CheckpointError(fmt::format(
      "{}: belongs to another run ({}); refusing to resume {} from it (nothing was changed)",
      checkpoint.string(), fmt::join(diffs, "; "), dir.string()));
}

// A checkpoint belongs to the run in `dir` when it stores the same scene as the directory's
// scene.toml in every key a resume may not change (the system, its start, the dynamics,
// the observables). Without scene.toml the run is known by its own checkpoint (where another
// one is named) or its summary.json; a directory that holds a run's files but none of these
// is refused. Refuses a checkpoint from another run before anything in `dir` changes.
void check_same_run(const fs::path &dir, const fs::path &checkpoint,
                    const std::string &scene_toml) {
  const fs::path scene_file = dir / "scene.toml";
  const auto theirs = identity_keys(scene_toml);
  std::error_code ec;
  if (fs::exists(scene_file, ec)) {
    std::string run_scene;
    try {
      run_scene = scene_to_toml(load_scene(scene_file.string()));
    } catch (const SceneError &e) {
      throw CheckpointError(
          fmt::format("{}: unreadable, so {} cannot be checked to belong to "
                      "this run: {}",
                      scene_file.string(), checkpoint.string(), e.what()));
    }
    return refuse_other_run(dir, checkpoint,
                            differences(identity_keys(run_scene), theirs, scene_file.string()));
  }
  for (const char *own : {kCheckpointFile, kPreviousCheckpointFile}) {
    const fs::path own_file = dir / own;
    if (!fs::exists(own_file, ec) || same_file(own_file, checkpoint)) continue;
    std::string own_scene;
    try {
      own_scene = read_checkpoint(own_file).scene_toml;
    } catch (const CheckpointError &) {
      continue;  // damaged: the next witness
    }
    return refuse_other_run(dir, checkpoint,
                            differences(identity_keys(own_scene), theirs, own_file.string()));
  }
  const fs::path summary_file = dir / "summary.json";
  if (fs::exists(summary_file, ec)) {
    const auto ours = summary_identity(summary_file, theirs);
    std::map<std::string, std::string> recorded;  // the checkpoint's keys that summary.json has
    for (const auto &[key, value] : ours) recorded[key] = theirs.at(key);
    return refuse_other_run(dir, checkpoint, differences(ours, recorded, summary_file.string()));
  }
  if (same_file(checkpoint.parent_path().empty() ? fs::path(".") : checkpoint.parent_path(), dir))
    return;  // the directory's own checkpoint
  for (const char *output : {"timeseries.csv", "trajectory.h5"})
    if (fs::exists(dir / output, ec))
      throw CheckpointError(fmt::format(
          "{}: holds a run ({}) but no scene.toml, checkpoint or summary.json to tell whether "
          "{} belongs to it; refusing to resume (nothing was changed): restore {} or resume "
          "into an empty directory",
          dir.string(), output, checkpoint.string(), scene_file.string()));
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
