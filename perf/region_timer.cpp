#include "perf/region_timer.hpp"

#include <fmt/format.h>

namespace hardrod {

const char *region_name(Region r) {
  switch (r) {
    case Region::kIntegrate:
      return "integrate";
    case Region::kNeighborBuild:
      return "neighbor_build";
    case Region::kDetect:
      return "detect";
    case Region::kResolve:
      return "resolve";
    case Region::kThermostat:
      return "thermostat";
    case Region::kObserve:
      return "observe";
    case Region::kFourier:
      return "fourier";
    case Region::kOutput:
      return "output";
    case Region::kAgree:
      return "agree";
    case Region::kCount:
      break;
  }
  return "?";
}

double RegionTimers::total_seconds() const {
  double t = 0.0;
  for (const auto &s : slots_) t += 1e-9 * s.nanoseconds;
  return t;
}

std::string RegionTimers::table(double particle_steps) const {
  std::string out = fmt::format("{:<16}{:>12}{:>8}{:>12}{:>14}{:>18}\n", "region", "seconds",
                                "share", "calls", "ns/call", "ns/particle-step");
  const double total = total_seconds();
  for (int r = 0; r < static_cast<int>(Region::kCount); ++r) {
    const auto &s = slots_[r];
    if (s.calls == 0) continue;
    const double sec = 1e-9 * s.nanoseconds;
    out +=
        fmt::format("{:<16}{:>12.3f}{:>7.1f}%{:>12}{:>14.0f}{:>18.2f}\n",
                    region_name(static_cast<Region>(r)), sec, total > 0 ? 100.0 * sec / total : 0.0,
                    s.calls, static_cast<double>(s.nanoseconds) / s.calls,
                    particle_steps > 0 ? s.nanoseconds / particle_steps : 0.0);
  }
  out += fmt::format("{:<16}{:>12.3f}{:>8}{:>12}{:>14}{:>18.2f}\n", "total", total, "", "", "",
                     particle_steps > 0 ? 1e9 * total / particle_steps : 0.0);
  return out;
}

}  // namespace hardrod
