// The program's clock: monotonic time, as std::chrono's steady_clock, read with
// clock_gettime(CLOCK_MONOTONIC). Under SimGrid's SMPI (the build of `scripts/build --smpi`),
// whose helpers header turns clock_gettime into its own, it is the simulated time of the rank:
// the region timers, the communication timers and the run's wall time then measure the
// simulated platform, not the machine that simulates it. There a reading also ends a stretch of
// computation, which the program may charge to the simulated clock itself
// (perf/simulated_compute.hpp); `place` names the reading for that.
#pragma once

#include <time.h>

#include <chrono>
#include <cstdint>
#include <source_location>

#include "perf/simulated_compute.hpp"

namespace hardrod {

struct ProgramClock {
  using duration = std::chrono::nanoseconds;
  using rep = duration::rep;
  using period = duration::period;
  using time_point = std::chrono::time_point<ProgramClock>;
  static constexpr bool is_steady = true;

  static time_point now(std::source_location where = std::source_location::current()) {
    return now_at(simulated::place_of(where));
  }
  static time_point now_at(std::uint64_t place) {
    simulated::charge(place);
    const time_point t = read();
    simulated::restart();
    return t;
  }
  // The reading before a communication call: the computation up to here is paid first.
  static time_point now_before_communication(std::uint64_t place) {
    simulated::charge(place);
    simulated::pay();
    const time_point t = read();
    simulated::restart();
    return t;
  }
  // The reading after one: the time since the last reading was the simulated network's.
  static time_point now_after_communication() {
    const time_point t = read();
    simulated::restart();
    return t;
  }

 private:
  static time_point read() {
    if (simulated::charging())  // the simulated clock without SMPI's cost of a reading
      return time_point(duration(static_cast<std::int64_t>(1e9 * simulated::now_seconds())));
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
