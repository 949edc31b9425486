// The program's clock: monotonic time, as std::chrono's steady_clock, read with
// clock_gettime(CLOCK_MONOTONIC). Under SimGrid's SMPI (the build of `scripts/build --smpi`),
// whose helpers header turns clock_gettime into its own, it is the simulated time of the rank:
// the region timers, the communication timers and the run's wall time then measure the
// simulated platform, not the machine that simulates it.
#pragma once

#include <time.h>

#include <chrono>
#include <cstdint>

namespace hardrod {

struct ProgramClock {
  using duration = std::chrono::nanoseconds;
  using rep = duration::rep;
  using period = duration::period;
  using time_point = std::chrono::time_point<ProgramClock>;
  static constexpr bool is_steady = true;

  static time_point now() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return time_point(duration(static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec));
  }
};

// Seconds between two readings.
inline double seconds_between(ProgramClock::time_point from, ProgramClock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

}  // namespace hardrod
