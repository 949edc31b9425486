// The checks a resume makes before it touches the run directory: only the step target and
// output intervals may change, the directory must exist, and a missing checkpoint with a
// previous one falls back to that one. (Resuming itself, exactly, is
// tests/scripts/check_checkpoint.py.)
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "runtime/resume.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

TEST(Resume, OnlyStepTargetAndOutputIntervalsMayChange) {
  try {
    find_resume_point("/nonexistent", {"run.steps=10", "run.dt=1e-3", "system.n=10"}, "");
    FAIL() << "expected SceneError";
  } catch (const SceneError &e) {
    ASSERT_EQ(e.problems().size(), 2u);
    EXPECT_NE(e.problems()[0].find("--set run.dt=1e-3: cannot be changed on resume"),
              std::string::npos);
  }
}

TEST(Resume, MissingRunDirectory) {
  EXPECT_THROW(find_resume_point("/nonexistent/hardrod-run", {"run.steps=10"}, ""),
               CheckpointError);
}

// A job killed between the checkpoint's two renames leaves only checkpoint.prev.h5: resume
// reads that one by itself (here it is junk, so the refusal names it).
TEST(Resume, MissingCheckpointFallsBackToThePreviousOne) {
  const fs::path dir = fs::temp_directory_path() / "hardrod-test-resume-previous";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / kPreviousCheckpointFile) << "x";
  try {
    find_resume_point(dir.string(), {}, "");
    FAIL() << "expected CheckpointError";
  } catch (const CheckpointError &e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(kPreviousCheckpointFile), std::string::npos) << message;
    EXPECT_EQ(message.find("--checkpoint"), std::string::npos) << message;  // read, not named
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hardrod
