// A random isotropic initial configuration at a target density: the start on the far side of
// the nematic from the aligned lattice (initial_state.hpp).
//
// How (after HOOMD-blue's hpmc QuickCompress): bodies are dropped at uniformly random
// positions with isotropic random axes into the target box scaled up to
// start_packing_fraction, overlaps allowed. Then, alternately:
// - a Monte Carlo sweep: every body once, in a random order, a translation uniform in a cube
//   or (rods, probability 1/2) a rotation, the axis plus a small isotropic random vector,
//   renormalised. A body without overlaps may not gain any. A body with overlaps may move
//   iff the sum of its overlap depths (D - axis distance) does not grow: every move changes
//   only the moved body's pairs, so the total depth never rises and overlapping bodies
//   drift apart. Move sizes adapt toward 20-40% acceptance.
// - when at most overlap_fraction * n / 2 pairs overlap, a box shrink toward the target,
//   centres scaled affinely, by up to max_shrink of a side; kept iff at most
//   overlap_fraction * n pairs overlap afterwards. Its step grows by 1.5 after a kept shrink
//   and halves after an undone one.
// At the target box, each sweep is followed by up to 10 passes over the bodies that still
// overlap. It ends when the box is the target box and no pair overlaps, which a final check
// of all pairs (fresh cell list) confirms.
//
// Why: box shrinks that must keep every pair apart are limited by the globally closest pair
// and crawl; shrinking during MD stalls. Tolerating a bounded number of overlaps lets the box
// shrink by up to percent steps. The depth rule instead of QuickCompress's "the overlap count
// may not grow": with the count rule overlapping bodies random-walk in their cages without
// healing (the everyday scene had not finished after 24000 sweeps; 2800 with the depth).
//
// Neither move knows of any direction, so the axes stay isotropic (S ~ 1/sqrt(n) plus the
// short-range correlations of the dense fluid). Overlap: axis segments closer than D
// (segment_closest, minimum image); every test of a pair is made in the same order (lower id
// first), so the counts kept during the run and the final check agree bit for bit.
// Neighbours: a Verlet list over cell_list.hpp (reach L + D + D/2 + room for 6 sweeps of
// the largest translation), rebuilt when the drift since the build or the shrink could let an
// unlisted pair touch, each body's list sorted by axis distance so that a rejected move
// usually stops at the first pair. Serial, one counter-based random stream keyed by the seed:
// the result depends on the seed only, not on the thread count. Runs once, before the MD.
// Cost (N = 2304, L/D = 5, rho* = 0.5, one core): 1300-2000 sweeps, 6-9 s.
#pragma once

#include <cstdint>
#include <functional>
#include <stdexcept>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

struct CompressionOptions {
  double start_packing_fraction = 0.05;  // random placement density (the target if lower)
  long long max_sweeps = 200000;         // give up after this many MC sweeps
  double max_seconds = 0;                // give up after this long; 0 = no limit
  double overlap_fraction = 0.2;         // overlapping pairs per body a box shrink may leave
  double max_shrink = 0.02;              // largest relative shrink of a side per box move
  // Asked between sweeps, if set: true ends the compression with CompressionStopped (a stop
  // signal during a long set-up).
  std::function<bool()> stop;
  // Called every progress_seconds of compression, if set, with the sweeps so far and the box
  // side over the target's, and once more where the compression gives up: a long set-up shows
  // that it moves, and a failed one where it stood (however fast it ran).
  std::function<void(long long sweeps, double box_scale)> progress;
  double progress_seconds = 5.0;
};

// The compression ended because CompressionOptions::stop asked for it.
class CompressionStopped : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CompressionReport {
  long long sweeps = 0;        // MC sweeps done
  long long compressions = 0;  // accepted box shrink steps
  double order_parameter = 0;  // S of the result (near 0: ~1/sqrt(n) for isotropic axes)
  // Smallest axis-segment distance minus D over all pairs (>= 0). Exact below D; pairs
  // whose centres are L + 2D or more apart are at least D apart, so a larger gap (dilute
  // systems, n = 1) is reported as D.
  double min_distance = 0;
  double seconds = 0;
  bool reached = false;  // target box reached without overlaps
  // State when a limit stopped the run (thrown): the box side over the target side, and
  // the overlapping pairs left.
  double box_scale = 1;
  long long overlapping_pairs = 0;
};

// n bodies with ids 0..n-1 (in that order), random positions folded into [0, side) and
// isotropic random unit axes, in the `target` box, no two overlapping. Deterministic for a
// given seed. Velocities, angular velocities and motion bounds are left zero (the caller
// calls assign_velocities).
// Throws std::invalid_argument for n < 1, a target box side not above 2 (L + D) (the
// minimum image must be unique, as for scenes) or options out of range; std::runtime_error
// with the reason if the target cannot be reached: a packing fraction at or above close
// packing, or max_sweeps / max_seconds exhausted (the report, if given, says how far it got).
Particles make_isotropic(long long n, const Shape &shape, const Box &target, std::uint64_t seed,
                         const CompressionOptions &options = {},
                         CompressionReport *report = nullptr);

}  // namespace hardrod
