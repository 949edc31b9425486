// likwid-style region timers: named after the phases of the time step (integrate, detect,
// resolve, neighbor_build, thermostat, observe, output, ...), accumulated as wall time and
// call counts, printed as a table at the end of a run. A region is opened with
// `ScopedRegion r(timers, Region::kDetect)`; the cost is two reads of the program's clock
// (perf/clock.hpp: the simulated time under SMPI).
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <string>

#include "perf/clock.hpp"

namespace hardrod {

enum class Region : int {
  kIntegrate = 0,
  kNeighborBuild,
  kDetect,
  kResolve,
  kThermostat,
  kObserve,
  kFourier,
  kOutput,
  kAgree,  // the step's one reduction, including the wait for the slowest rank
  kCount
};

const char *region_name(Region r);

class RegionTimers {
 public:
  void add(Region r, std::int64_t nanoseconds) {
    auto &slot = slots_[static_cast<int>(r)];
    slot.nanoseconds += nanoseconds;
    ++slot.calls;
  }
  double seconds(Region r) const { return 1e-9 * slots_[static_cast<int>(r)].nanoseconds; }
  std::int64_t calls(Region r) const { return slots_[static_cast<int>(r)].calls; }
  double total_seconds() const;
  // Table: region, seconds, share, calls, ns per call and, if `particle_steps` > 0,
  // ns per particle-step.
  std::string table(double particle_steps) const;

 private:
  struct Slot {
    std::int64_t nanoseconds = 0;
    std::int64_t calls = 0;
  };
  std::array<Slot, static_cast<int>(Region::kCount)> slots_{};
};

class ScopedRegion {
 public:
  ScopedRegion(RegionTimers &timers, Region region)
      : timers_(timers), region_(region), start_(ProgramClock::now_at(place(0))) {}
  ~ScopedRegion() {
    timers_.add(region_, std::chrono::duration_cast<std::chrono::nanoseconds>(
                             ProgramClock::now_at(place(1)) - start_)
                             .count());
  }
  ScopedRegion(const ScopedRegion &) = delete;
  ScopedRegion &operator=(const ScopedRegion &) = delete;

 private:
  std::uint64_t place(int end) const { return 2 * static_cast<std::uint64_t>(region_) + end + 1; }
  RegionTimers &timers_;
  Region region_;
  ProgramClock::time_point start_;
};

}  // namespace hardrod
