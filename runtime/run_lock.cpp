// The run directory's lock (see run_lock.hpp).
#include "runtime/run_lock.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "runtime/scene.hpp"

namespace hardrod {

namespace {

// The pid the holder wrote into the lock file, or "unknown" (it may not have written it yet).
std::string holder_pid(int fd) {
  char text[32] = {};
  const ssize_t got = pread(fd, text, sizeof text - 1, 0);
  std::string pid = got > 0 ? std::string(text, static_cast<std::size_t>(got)) : "";
  while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
  return pid.empty() ? "unknown" : pid;
}

}  // namespace

RunLock::RunLock(const std::filesystem::path &dir) {
  const std::string path = (dir / kLockFile).string();
  fd_ = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw SceneError({fmt::format("{}: cannot create the run directory's lock: {}", path,
                                  std::strerror(errno))});
  if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int error = errno;
    const std::string pid = holder_pid(fd_);
    close(fd_);
    fd_ = -1;
    if (error == EWOULDBLOCK)
      throw SceneError({fmt::format(
          "{}: in use by another hardrod process (pid {}, lock {}); wait for it to end, or "
          "stop it (kill -TERM {} leaves a checkpoint), then resume",
          dir.string(), pid, path, pid)});
    throw SceneError({fmt::format("{}: cannot lock: {}", path, std::strerror(error))});
  }
  const std::string pid = std::to_string(getpid()) + "\n";
  if (ftruncate(fd_, 0) != 0 || pwrite(fd_, pid.data(), pid.size(), 0) < 0) {
    // The pid is only for another process's message: the lock holds without it.
  }
}

RunLock::~RunLock() {
  if (fd_ >= 0) close(fd_);  // releases the flock
}

}  // namespace hardrod
