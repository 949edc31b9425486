// The computation a rank charges to the simulated clock under SimGrid's SMPI (the build of
// `scripts/build --smpi`). By default SMPI times each stretch of computation between two MPI
// calls itself. With HARDROD_SMPI_COMPUTE set, the program charges them (smpirun must then be
// told --cfg=smpi/simulate-computation:no, as `scripts/bench scaling --simulate` does):
//   measured  every stretch as timed, on the thread's CPU clock, as SMPI would;
//   filtered  the same, less this machine's noise: a stretch is charged at most 1.2 times the
//             median of the last 31 between the same two places of the program, on any rank,
//             plus 1 us.
// Why filter: the ranks run one after the other on one core here, and this machine stalls a
// few microseconds of work by 50-120 us a few hundred times a second (a virtual machine's
// timer interrupts). With hundreds of ranks, almost every step holds a stalled stretch on some
// rank, which the step's reductions hand to all: the simulation measured the host's jitter,
// not the platform's. A place is a clock reading's source line or a communication's name.
//
// Not under SMPI, or with HARDROD_SMPI_COMPUTE unset, every function here does nothing.
#pragma once

#include <cstdint>
#include <source_location>

namespace hardrod::simulated {

// What this rank charged: stretches, their seconds, and how many seconds the filter took off.
struct ComputeTotals {
  long long stretches = 0;
  long long clipped = 0;
  double charged_seconds = 0.0;
  double clipped_seconds = 0.0;
};

#ifdef HARDROD_SMPI
// True when the program charges its computation (HARDROD_SMPI_COMPUTE set).
bool charging();
// Ends a stretch of computation at `place`: its time (filtered) joins what this rank owes the
// simulated clock, and the next stretch starts.
void charge(std::uint64_t place);
// Pays what this rank owes: the simulated host computes it (before a communication call, which
// must start at the simulated time the computation ends). Paying only there keeps the number
// of simulated activities, whose cost grows with the ranks, to the communication's.
void pay();
// Starts a stretch without charging the time since the last one (after a communication call
// or a clock reading: that time was the simulator's).
void restart();
// The rank's simulated time, what it owes included, in seconds.
double now_seconds();
ComputeTotals totals();
#else
inline bool charging() { return false; }
inline void charge(std::uint64_t) {}
inline void pay() {}
inline void restart() {}
inline double now_seconds() { return 0.0; }
inline ComputeTotals totals() { return {}; }
#endif

// A place in the source, for charge().
inline std::uint64_t place_of(const std::source_location &where) {
  return (reinterpret_cast<std::uintptr_t>(where.file_name()) << 16) ^ where.line();
}

}  // namespace hardrod::simulated
