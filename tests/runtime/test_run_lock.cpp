// The run directory's lock (runtime/run_lock.hpp): a second holder is refused with the first
// one's pid, the lock goes with its holder, and a lock file left by a dead process (kill -9)
// does not block.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "runtime/run_lock.hpp"
#include "runtime/scene.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string &name) {
  const fs::path dir = fs::temp_directory_path() / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(RunLock, OneHolderAtATimeNamedByPid) {
  const fs::path dir = fresh_dir("hardrod-test-lock");
  {
    const RunLock first(dir);
    try {
      const RunLock second(dir);  // another open file description: flock conflicts
      FAIL() << "a second lock of one directory must be refused";
    } catch (const SceneError &e) {
      const std::string message = e.what();
      EXPECT_NE(
          message.find("in use by another hardrod process (pid " + std::to_string(getpid()) + ","),
          std::string::npos)
          << message;
    }
  }
  EXPECT_NO_THROW(RunLock again(dir));  // released with its holder
  fs::remove_all(dir);
}

TEST(RunLock, StaleLockFileDoesNotBlock) {
  const fs::path dir = fresh_dir("hardrod-test-lock-stale");
  std::ofstream(dir / kLockFile) << "999999999\n";  // a holder that died without unlocking
  EXPECT_NO_THROW(RunLock taken(dir));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hardrod
