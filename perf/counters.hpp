// Hardware counters (instructions, cycles, cache misses) for a whole run, through Linux
// perf_event_open, one counter set per OpenMP thread, summed. Where the kernel or the
// hypervisor does not offer them (as on many VMs), every value says "not available" and
// why; nothing else changes.
#pragma once

#include <string>
#include <vector>

namespace hardrod {

class HardwareCounters {
 public:
  // Opens and starts the counters on every OpenMP thread (call outside parallel regions).
  void start();
  // Stops them and reads the sums.
  void stop();

  bool available() const { return available_; }
  const std::string &reason() const { return reason_; }  // why not, when not available
  // name -> total over threads; empty when not available.
  const std::vector<std::pair<std::string, long long>> &values() const { return values_; }
  std::string report() const;  // one line

 private:
  bool available_ = false;
  std::string reason_ = "not started";
  std::vector<std::vector<int>> fds_;  // per thread, per event
  std::vector<std::pair<std::string, long long>> values_;
};

}  // namespace hardrod
