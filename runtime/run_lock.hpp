// One process at a time in a run directory: an advisory lock (flock) on DIR/hardrod.lock,
// taken by rank 0 of a run or a resume before it writes anything there, and held until the
// process ends. The kernel drops a flock when its holder dies, so the lock of a killed run
// (kill -9, a node lost) never blocks the next one; the file stays and holds the last
// holder's pid, only for the message.
#pragma once

#include <filesystem>

namespace hardrod {

inline constexpr const char *kLockFile = "hardrod.lock";

class RunLock {
 public:
  // Takes the lock of `dir` (which must exist), or throws SceneError naming the directory
  // and the pid of the process that holds it.
  explicit RunLock(const std::filesystem::path &dir);
  ~RunLock();
  RunLock(const RunLock &) = delete;
  RunLock &operator=(const RunLock &) = delete;

 private:
  int fd_ = -1;
};

}  // namespace hardrod
