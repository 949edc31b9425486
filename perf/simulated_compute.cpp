// Charging the computation to SMPI's simulated clock (see the header).
#include "perf/simulated_compute.hpp"

#ifdef HARDROD_SMPI

#include <simgrid/actor.h>
#include <simgrid/engine.h>
#include <simgrid/host.h>
#include <smpi/smpi.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <unordered_map>

namespace hardrod::simulated {

namespace {

constexpr int kWindow = 31;       // stretches remembered per pair of places, over all ranks
constexpr int kFirstFilter = 5;   // stretches seen before the filter acts
// A stretch is charged at most factor() x the median + kSlack; HARDROD_SMPI_FILTER sets the
// factor (a study of the filter itself: 0 charges nothing but the slack).
double factor_from_environment() {
  const char *v = std::getenv("HARDROD_SMPI_FILTER");
  return v != nullptr && *v != '\0' ? std::strtod(v, nullptr) : 1.2;
}
const double kFactor = factor_from_environment();
constexpr double kSlack = 1e-6;   // seconds

enum class Mode { kOff, kMeasured, kFiltered };

Mode mode_from_environment() {
  const char *v = std::getenv("HARDROD_SMPI_COMPUTE");
  if (v == nullptr || *v == '\0') return Mode::kOff;
  return std::strcmp(v, "measured") == 0 ? Mode::kMeasured : Mode::kFiltered;
}

const Mode kMode = mode_from_environment();

double cpu_seconds() {
  timespec ts{};
  (clock_gettime)(CLOCK_THREAD_CPUTIME_ID, &ts);  // the real clock, not SMPI's
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

// What one reading of the thread's CPU clock costs (a system call in a virtual machine, about
// 1 us here): a stretch holds about one, which is taken off.
double reading_cost() {
  std::array<double, 101> t{};
  for (double &x : t) {
    const double a = cpu_seconds();
    x = cpu_seconds() - a;
  }
  std::nth_element(t.begin(), t.begin() + 50, t.end());
  return t[50];
}

struct Recent {
  std::array<double, kWindow> seconds{};
  int seen = 0;
  double limit() const {
    std::array<double, kWindow> s = seconds;
    const int n = std::min(seen, kWindow);
    std::nth_element(s.begin(), s.begin() + n / 2, s.begin() + n);
    return kFactor * s[static_cast<std::size_t>(n / 2)] + kSlack;
  }
  void add(double t) { seconds[static_cast<std::size_t>(seen++ % kWindow)] = t; }
};

// One per rank: all ranks are actors of one process and one thread (smpirun -no-privatize).
struct Rank {
  double mark = -1.0;
  double owed = 0.0;  // seconds charged, not yet computed by the simulated host
  std::uint64_t last_place = 0;
  ComputeTotals totals;
};

// The recent stretches between two places, of every rank: in a system of equal subdomains a
// rank's stretch is measured against the others' too, so that a rank this machine slows
// throughout (its place in the simulator's schedule, its arrays' addresses) is not the slowest.
std::unordered_map<std::uint64_t, Recent> recent_;

// A deque: growing it keeps the references of the ranks that hold one across a simulated call.
std::deque<Rank> ranks_;

Rank &this_rank() {
  const auto pid = static_cast<std::size_t>(sg_actor_self_get_pid());
  if (pid >= ranks_.size()) ranks_.resize(pid + 1);
  return ranks_[pid];
}

}  // namespace

bool charging() { return kMode != Mode::kOff; }

void charge(std::uint64_t place) {
  if (kMode == Mode::kOff) return;
  Rank &r = this_rank();
  const double now = cpu_seconds();
  if (r.mark >= 0.0) {
    static const double cost = reading_cost();
    double t = std::max(0.0, now - r.mark - cost);
    if (kMode == Mode::kFiltered) {
      Recent &recent = recent_[r.last_place * 1000003u ^ place];
      const double limit = recent.seen >= kFirstFilter ? recent.limit() : t;
      recent.add(t);
      if (t > limit) {
        r.totals.clipped += 1;
        r.totals.clipped_seconds += t - limit;
        t = limit;
      }
    }
    r.totals.stretches += 1;
    r.totals.charged_seconds += t;
    r.owed += t;
  }
  r.last_place = place;
  r.mark = now;
}

void pay() {
  if (kMode == Mode::kOff) return;
  Rank &r = this_rank();
  const double owed = r.owed;
  if (owed <= 0.0) return;
  r.owed = 0.0;
  // As flops at the host's speed: smpi_execute would drop stretches under smpi/cpu-threshold.
  smpi_execute_flops_benched(owed * sg_host_get_speed(sg_host_self()));
}

void restart() {
  if (kMode == Mode::kOff) return;
  this_rank().mark = cpu_seconds();
}

double now_seconds() { return simgrid_get_clock() + this_rank().owed; }

ComputeTotals totals() { return kMode == Mode::kOff ? ComputeTotals{} : this_rank().totals; }

}  // namespace hardrod::simulated

#endif
