// run_scene and resume_run: a RunLoop from the scene or from the checkpoint (see run.hpp).
#include "runtime/run.hpp"

#include <fmt/format.h>

#include "runtime/resume.hpp"
#include "runtime/run_loop.hpp"

namespace hardrod {

nlohmann::json run_scene(const Scene &scene, const RunOptions &options) {
  return RunLoop(scene, options, nullptr).run();
}

nlohmann::json resume_run(const std::string &dir, const std::vector<std::string> &overrides,
                          const RunOptions &options, const std::string &checkpoint_path) {
  const ResumePoint from = find_resume_point(dir, overrides, checkpoint_path);
  if (!from.note.empty() && Communicator().is_root())
    fmt::print(stderr, "hardrod: {}\n", from.note);
  RunOptions o = options;
  o.output_dir = dir;
  return RunLoop(from.scene, o, &from.checkpoint).run();
}

}  // namespace hardrod
