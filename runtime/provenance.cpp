// The process's provenance (see provenance.hpp).
#include "runtime/provenance.hpp"

#include <unistd.h>

#include <array>
#include <vector>

#include "hardrod_git_commit.hpp"  // generated at build time: HARDROD_GIT_COMMIT
#include "runtime/comm.hpp"

namespace hardrod {

namespace {

Provenance &state() {
  static Provenance p = [] {
    Provenance q;
    q.version = HARDROD_VERSION;
    q.git_commit = HARDROD_GIT_COMMIT;
    q.started_at = iso8601_utc(std::time(nullptr));
    std::array<char, 256> name{};
    q.host = gethostname(name.data(), name.size() - 1) == 0 ? name.data() : "unknown";
    return q;
  }();
  return p;
}

}  // namespace

void record_command_line(int argc, const char *const *argv) {
  Provenance &p = state();
  p.started_at = iso8601_utc(std::time(nullptr));
  p.command_line.clear();
  for (int k = 0; k < argc; ++k) {
    if (k > 0) p.command_line += ' ';
    p.command_line += shell_quote(argv[k]);
  }
}

const Provenance &process_provenance() { return state(); }

Provenance agreed_provenance(Communicator &comm) {
  if (comm.size() == 1) return process_provenance();
  const std::string text = provenance_json(process_provenance()).dump();
  std::vector<char> size(sizeof(long long));
  const auto length = static_cast<long long>(text.size());
  std::copy_n(reinterpret_cast<const char *>(&length), sizeof length, size.begin());
  comm.broadcast("summary", size);
  long long root_length = 0;
  std::copy_n(size.begin(), sizeof root_length, reinterpret_cast<char *>(&root_length));
  std::vector<char> bytes(static_cast<std::size_t>(root_length));
  if (comm.is_root()) std::copy(text.begin(), text.end(), bytes.begin());
  comm.broadcast("summary", bytes);
  const auto j = nlohmann::json::parse(bytes.begin(), bytes.end());
  return {j.at("version"), j.at("git_commit"), j.at("command_line"), j.at("started_at"),
          j.at("host")};
}

nlohmann::json provenance_json(const Provenance &p) {
  return {{"version", p.version},
          {"git_commit", p.git_commit},
          {"command_line", p.command_line},
          {"started_at", p.started_at},
          {"host", p.host}};
}

std::string iso8601_utc(std::time_t t) {
  std::tm utc{};
  gmtime_r(&t, &utc);
  std::array<char, 32> text{};
  std::strftime(text.data(), text.size(), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text.data();
}

std::string shell_quote(const std::string &word) {
  const bool safe = !word.empty() && word.find_first_not_of(
                                         "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"
                                         "0123456789_-+=.,:/@%") == std::string::npos;
  if (safe) return word;
  std::string out = "'";
  for (char c : word) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace hardrod
