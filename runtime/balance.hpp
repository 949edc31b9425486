// Dynamic load balancing: the domain's cuts (runtime/domain.hpp) move so that every slab
// of ranks along an axis carries the same load. Slabs, not single ranks: the cuts along an
// axis are shared by all ranks of a slab, so the grid stays a grid and the partners stay
// neighbours (the "shift" scheme of LAMMPS' balance command; GROMACS staggers its cells).
//
// The load of a rank is either its compute time since the last check (free flight and
// detection: no waiting for other ranks in them; it also sees a core that the machine slows
// down) or the number of bodies it advances (deterministic). Every
// `interval` steps the ranks sum their loads per slab (exact sums: every rank computes the
// same cuts) and, when the busiest rank carries more than `threshold` above the mean, move
// the cuts. New cuts take effect at a neighbour-list rebuild, where bodies migrate anyway:
// the next one, or at once (a forced rebuild) when the time the ranks lost in the last
// interval exceeds what a rebuild costs. Cuts never change the trajectory: the state is the
// same, bit for bit, for any decomposition.
#pragma once

#include <string>
#include <vector>

namespace hardrod {

enum class BalanceMode { kOff, kBodies, kTime };

struct BalanceOptions {
  BalanceMode mode = BalanceMode::kTime;
  long long interval = 1000;  // steps between checks
  double threshold = 0.05;    // busiest rank's load above the mean, relative
};

// "off", "bodies", "time"; throws std::invalid_argument naming the value otherwise.
BalanceMode parse_balance_mode(const std::string &name);
const char *balance_mode_name(BalanceMode mode);

// New cuts along one axis (cuts.size() = slabs + 1, from 0 to the side). The load of slab s
// is taken as spread evenly over [cuts[s], cuts[s + 1]); the returned cuts give every slab
// the same share, except that no slab gets thinner than `min_width` (then the cuts take the
// largest step towards that target that keeps every slab at least that wide; cuts that
// already violate it are left alone). Any shift is allowed: the rebuild moves the cuts in
// stages (System::take_new_cuts). Loads that are not finite and positive leave the cuts
// unchanged.
std::vector<double> balanced_cuts(const std::vector<double> &cuts, const std::vector<double> &loads,
                                  double min_width);

}  // namespace hardrod
