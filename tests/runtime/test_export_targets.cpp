// What `hardrod export --out` may replace (runtime/export.hpp, check_export_target): a
// regular file, or nothing; never a directory, a FIFO, a device, a symbolic link, the input
// or a run's own file beside it, and nothing is changed when one is refused. And the format
// of an .h5 name, which is never guessed.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "runtime/export.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

// A fake run directory: trajectory.h5 and checkpoint.h5 with some bytes, and a file of the
// user's beside them.
struct RunDir {
  fs::path dir;
  RunDir() {
    dir = fs::temp_directory_path() / ("hardrod-export-targets-" + std::to_string(getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    for (const char *name : {"trajectory.h5", "checkpoint.h5", "mine.xyz"})
      std::ofstream(dir / name) << name;
  }
  ~RunDir() { fs::remove_all(dir); }
  std::string input() const { return (dir / "trajectory.h5").string(); }
};

// The message of check_export_target's refusal, or "" if it accepts `out`.
std::string refusal(const std::string &input, const std::string &out) {
  try {
    check_export_target(input, out);
  } catch (const std::invalid_argument &e) {
    return e.what();
  }
  return "";
}

TEST(ExportTargets, RegularFilesAndNewNamesAreAccepted) {
  const RunDir run;
  EXPECT_EQ(refusal(run.input(), (run.dir / "mine.xyz").string()), "");
  EXPECT_EQ(refusal(run.input(), (run.dir / "new.gsd").string()), "");
  EXPECT_EQ(refusal(run.input(), (run.dir / "trajectory.xyz").string()), "");
}

TEST(ExportTargets, AnythingButARegularFileIsRefusedByName) {
  const RunDir run;
  fs::create_directory(run.dir / "folder");
  ASSERT_EQ(mkfifo((run.dir / "pipe").c_str(), 0600), 0);
  fs::create_symlink(run.dir / "mine.xyz", run.dir / "link.xyz");
  fs::create_symlink(run.dir / "nowhere", run.dir / "dangling.xyz");
  const std::string folder = (run.dir / "folder").string(), pipe = (run.dir / "pipe").string(),
                    link = (run.dir / "link.xyz").string(),
                    dangling = (run.dir / "dangling.xyz").string();
  EXPECT_NE(refusal(run.input(), folder).find("--out " + folder + ": it is a directory"),
            std::string::npos);
  EXPECT_NE(refusal(run.input(), pipe).find("a FIFO"), std::string::npos);
  EXPECT_NE(refusal(run.input(), link).find("--out " + link + ": it is a symbolic link"),
            std::string::npos);
  EXPECT_NE(refusal(run.input(), dangling).find("symbolic link"), std::string::npos);
  // The temporary file export writes first is held to the same rule.
  fs::create_symlink(run.dir / "mine.xyz", run.dir / "out.xyz.tmp");
  EXPECT_NE(refusal(run.input(), (run.dir / "out.xyz").string()).find("temporary file"),
            std::string::npos);
  struct stat before {};
  ASSERT_EQ(stat("/dev/null", &before), 0);
  EXPECT_NE(refusal(run.input(), "/dev/null").find("a device"), std::string::npos);
  struct stat after {};
  ASSERT_EQ(stat("/dev/null", &after), 0);
  EXPECT_TRUE(S_ISCHR(after.st_mode) && after.st_ino == before.st_ino &&
              after.st_rdev == before.st_rdev);
  EXPECT_TRUE(fs::is_fifo(pipe) && fs::is_symlink(link) && fs::is_directory(folder));
}

TEST(ExportTargets, TheInputAndTheRunsOwnFilesAreRefused) {
  const RunDir run;
  EXPECT_NE(refusal(run.input(), run.input()).find("is the input file itself"), std::string::npos);
  for (const char *own :
       {"checkpoint.h5", "checkpoint.prev.h5", "scene.toml", "summary.json", "timeseries.csv",
        "frank.json", "analysis.json", "angular.json", "hardrod.lock"}) {
    const std::string out = (run.dir / own).string();
    EXPECT_NE(refusal(run.input(), out).find(std::string(own) + " is one of the run's own files"),
              std::string::npos)
        << own;
  }
  // By identity: the run's directory by another path, the checkpoint under another name.
  fs::create_directory_symlink(run.dir, run.dir.string() + "-alias");
  EXPECT_NE(refusal(run.input(), run.dir.string() + "-alias/summary.json"), "");
  fs::create_hard_link(run.dir / "checkpoint.h5", run.dir / "hard.xyz");
  EXPECT_NE(refusal(run.input(), (run.dir / "hard.xyz").string()).find("the same file as"),
            std::string::npos);
  fs::remove(run.dir.string() + "-alias");
}

TEST(ExportTargets, AnH5NameTakesXyzOnlyWhenAskedFor) {
  for (const char *name : {"x.h5", "d/out.hdf5", "x.h5md"}) try {
      choose_export_format("", name);
      ADD_FAILURE() << name;
    } catch (const std::invalid_argument &e) {
      EXPECT_NE(std::string(e.what()).find("--format xyz"), std::string::npos) << e.what();
    }
  EXPECT_EQ(choose_export_format("xyz", "x.h5"), ExportFormat::kXyz);
  EXPECT_EQ(choose_export_format("", "x.pov"), ExportFormat::kPov);
  EXPECT_EQ(choose_export_format("pov", ""), ExportFormat::kPov);
}

}  // namespace
}  // namespace hardrod
