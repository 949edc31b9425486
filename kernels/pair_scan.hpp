// The walk over a neighbour list's pairs that finds the pairs due for the narrow phase: those
// whose two motion bounds used up their slack (kernels/neighbor_list.hpp). It knows no physics:
// what a due pair becomes is its caller's (a DueMeasure): the midpoint method's contacts
// (kernels/contact_detection.hpp), the exact method's candidates (kernels/exact/
// step_candidates.hpp). Three ways through the list, the same pairs due in each:
//  - the watches: only the pairs of bodies whose bound reached their watch are read, in a team
//    of threads over blocks of bodies; every visited pair's slack is split again between its
//    bodies (allowances);
//  - the near pairs (NearPairs): a full pass lists the pairs whose slack left is below a reach,
//    and the passes after read those alone while they hold;
//  - the full pass over every pair, split into blocks of pairs over the threads.
// Reads the motion bounds (and Particles::grow for the near pairs' reach); writes the list's
// allowances, watches and near pairs; the measure writes the slacks it renews.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/neighbor_list.hpp"
#include "kernels/particles.hpp"

namespace hardrod {

// What a scan's caller does with the due pairs. Every thread of a scan calls measure with its
// own thread number and its own pairs; the caller keeps each thread's results apart and
// merges them after the scan.
class DueMeasure {
 public:
  virtual ~DueMeasure() = default;
  // Storage for a scan by up to `threads` threads.
  virtual void start(int threads) = 0;
  // The due pairs list.pairs[due[0, n)] measured (their slacks renewed from the distance) on
  // thread `thread`; the deepest overlap into max_depth.
  virtual void measure(int thread, const Particles &p, NeighborList &list, const std::uint32_t *due,
                       std::size_t n, double &max_depth) = 0;
  // Added to every body's motion bound when it is tested against its watch, and twice it to a
  // pair's two bounds when the pair is tested for due (the exact method's overrun allowance,
  // whose pairs come as spares; 0 for the midpoint method).
  double allowance = 0.0;
};

struct DetectionStats {
  long long narrow_phase_tests = 0;  // due pairs measured (segment distances computed)
  double max_depth = 0.0;            // deepest overlap this step (0 if none)
  bool watched = false;              // through the watches, not a pass over every pair
  bool near = false;                 // a pass over the list's near pairs only (NearPairs)
};

// The watched scan's parts, for a team of threads that has other work in the same parallel
// region (the midpoint method's drift, kernels/free_flight.hpp): every thread of the team calls
// scan_watched_in_team (it has barriers), then one thread calls finish_watched_scan, which
// switches the list to the full pass and runs it where too many bodies were flagged (watching
// false). The measure is started for `threads` threads by the caller.
struct WatchedTeam {
  explicit WatchedTeam(int threads);
  std::vector<std::vector<std::uint32_t>> due;  // each thread's pairs to measure
  std::vector<long> ends;
  std::vector<long long> tests;
  std::vector<double> depth;
  bool watching = true;
};
void scan_watched_in_team(const Particles &p, NeighborList &list, WatchedTeam &team,
                          DueMeasure &measure);
DetectionStats finish_watched_scan(const Particles &p, NeighborList &list, WatchedTeam &team,
                                   DueMeasure &measure);

// The due pairs of one step: through the watches while the list keeps them, else a pass over
// the near pairs or every pair. Starts the measure.
DetectionStats scan_pairs(const Particles &p, NeighborList &list, DueMeasure &measure);

// The reference: a pass over every listed pair, the near pairs neither used nor made. It renews
// slacks but not allowances: a list it has used is not fit for scan_pairs until arm_watches.
DetectionStats scan_every_pair(const Particles &p, NeighborList &list, DueMeasure &measure);

}  // namespace hardrod
