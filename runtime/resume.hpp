// Where a resume starts: the checks made before anything in the run directory is touched
// (which --set keys may change, which checkpoint file, whether the stored scene and the raised
// step target fit it). Running from the checkpoint is RunLoop's (run_loop.hpp).
#pragma once

#include <string>
#include <vector>

#include "runtime/checkpoint.hpp"
#include "runtime/scene.hpp"

namespace hardrod {

struct ResumePoint {
  Checkpoint checkpoint;
  Scene scene;       // the checkpoint's scene with the overrides applied
  std::string note;  // what the user should know (a fallback to the previous checkpoint)
};

// Reads `checkpoint_path` (default: dir/checkpoint.h5, or dir/checkpoint.prev.h5 when that is
// missing, with a note) and the scene it stores with `overrides` (only run.steps and output
// intervals may change). Throws CheckpointError for an unusable checkpoint or one that
// belongs to another run (its scene differs from dir/scene.toml), and SceneError for a bad
// override.
ResumePoint find_resume_point(const std::string &dir, const std::vector<std::string> &overrides,
                              const std::string &checkpoint_path);

}  // namespace hardrod
