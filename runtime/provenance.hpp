// Where a run's numbers came from: the build (version, git commit), the command line, when
// and on which host the process started. summary.json and the H5MD trajectory's /parameters
// carry it, so a result found months later can be traced to the code and the call that made
// it. The git commit is taken at build time (cmake/git_commit.cmake), "unknown" outside git.
#pragma once

#include <ctime>
#include <nlohmann/json.hpp>
#include <string>

namespace hardrod {

class Communicator;

struct Provenance {
  std::string version;       // the project's version (CMake project VERSION)
  std::string git_commit;    // `git describe --always --dirty` of the build, or "unknown"
  std::string command_line;  // the arguments, shell-quoted; "" if none was recorded
  std::string started_at;    // ISO 8601 UTC, when the command line was recorded
  std::string host;          // the host name
};

// Records this process's command line and start time; main() calls it first. Without it
// (unit tests) the command line is empty and the start time that of the first query.
void record_command_line(int argc, const char *const *argv);

// This process's provenance.
const Provenance &process_provenance();

// Collective: rank 0's provenance on every rank, so that every rank's summary is the same.
Provenance agreed_provenance(Communicator &comm);

// {"version", "git_commit", "command_line", "started_at", "host"}.
nlohmann::json provenance_json(const Provenance &p);

// "2026-11-25T12:34:56Z".
std::string iso8601_utc(std::time_t t);

// `word` as a POSIX shell reads it back: unchanged if it holds only safe characters, else in
// single quotes.
std::string shell_quote(const std::string &word);

}  // namespace hardrod
