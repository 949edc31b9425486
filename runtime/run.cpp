// run_scene and resume_run: a RunLoop from the scene or from the checkpoint (see run.hpp).
#include "runtime/run.hpp"

#include <fmt/format.h>

#include "runtime/resume.hpp"
#include "runtime/run_loop.hpp"

namespace hardrod {

namespace {

// The scene as run: output.dir is the directory the run writes (--out, or resume's DIR), so
// that scene.toml and the checkpoint's copy say where the run actually went.
Scene as_run(const Scene &scene, const RunOptions &options) {
  Scene s = scene;
  if (!options.output_dir.empty()) s.output_dir = options.output_dir;
  return s;
}

}  // namespace

nlohmann::json run_scene(const Scene &scene, const RunOptions &options) {
  const Scene s = as_run(scene, options);
  return RunLoop(s, options, nullptr).run();
}

nlohmann::json resume_run(const std::string &dir, const std::vector<std::string> &overrides,
                          const RunOptions &options, const std::string &checkpoint_path) {
  const ResumePoint from = find_resume_point(dir, overrides, checkpoint_path);
  if (!from.note.empty() && Communicator().is_root())
    fmt::print(stderr, "hardrod: {}\n", from.note);
  RunOptions o = options;
  o.output_dir = dir;
  const Scene s = as_run(from.scene, o);
  return RunLoop(s, o, &from.checkpoint).run();
}

}  // namespace hardrod
