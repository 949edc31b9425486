// The load balancer's decisions (the cuts' arithmetic is runtime/balance.cpp): the cuts a
// run starts from, and every `interval` steps the comparison of the ranks' loads that sets
// new cuts for the next rebuild, forcing one when that pays. Every rank computes the same
// cuts from exact sums. Not here: moving bodies to new cuts (runtime/decomposition.cpp).
#include <algorithm>
#include <cmath>

#include "runtime/system.hpp"

namespace hardrod {

// Cuts that share the bodies out evenly along each axis at the start (a few passes of the
// balancer on the slabs' counts; the same on every rank).
Cuts System::starting_cuts(const SlabCounts &counts) const {
  const auto &grid = domain_.grid();
  Cuts cuts = domain_.cuts();
  const double sides[3] = {scene_.box.length.x, scene_.box.length.y, scene_.box.length.z};
  for (int pass = 0; pass < 4; ++pass)
    for (int a = 0; a < 3; ++a) {
      if (grid[a] < 2) continue;
      cuts[a] = balanced_cuts(cuts[a], counts(a, cuts[a]), 0.5 * sides[a] / grid[a]);
    }
  return cuts;
}

void System::check_balance() {
  const auto &grid = domain_.grid();
  double load = static_cast<double>(advanced());
  if (balance_.mode == BalanceMode::kTime) {
    // Compute time: the free flight and the detection, most of a step and free of waits
    // for other ranks (list builds, the thermostat and resolution include exchanges).
    const double busy = timers_.seconds(Region::kIntegrate) + timers_.seconds(Region::kDetect);
    load = std::max(0.0, busy - busy_mark_);
    busy_mark_ = busy;
  }
  // Loads per slab along each axis, and in all: exact sums, so every rank gets the same bits
  // and computes the same cuts.
  const auto c = domain_.coords(comm_.rank());
  std::vector<ExactSum> sums(static_cast<std::size_t>(grid[0] + grid[1] + grid[2]) + 1);
  sums[static_cast<std::size_t>(c[0])].add(load);
  sums[static_cast<std::size_t>(grid[0] + c[1])].add(load);
  sums[static_cast<std::size_t>(grid[0] + grid[1] + c[2])].add(load);
  sums.back().add(load);
  sums = comm_.sum("balance", sums);
  const double builds =
      static_cast<double>(std::max<std::int64_t>(1, timers_.calls(Region::kNeighborBuild)));
  const std::vector<double> most =
      comm_.max("balance", {load, timers_.seconds(Region::kNeighborBuild) / builds});
  const double mean = sums.back().value() / comm_.size();
  if (!(mean > 0.0)) return;
  const double imbalance = most[0] / mean - 1.0;
  if (balanced_.checks == 0) balanced_.first_imbalance = imbalance;
  ++balanced_.checks;
  balanced_.last_imbalance = imbalance;
  balanced_.max_imbalance = std::max(balanced_.max_imbalance, imbalance);
  if (!(imbalance > balance_.threshold)) return;

  Cuts cuts = domain_.cuts();
  bool moved = false;
  int first = 0;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> loads;
    for (int k = 0; k < grid[a]; ++k)
      loads.push_back(sums[static_cast<std::size_t>(first + k)].value());
    first += grid[a];
    if (grid[a] < 2) continue;
    const double side = cuts[a].back();
    // Slabs no thinner than half the even share (more partners, more shadows).
    const auto next = balanced_cuts(cuts[a], loads, 0.5 * side / grid[a]);
    for (std::size_t k = 0; k < next.size(); ++k)
      moved = moved || std::fabs(next[k] - cuts[a][k]) > 1e-3 * side / grid[a];
    cuts[a] = next;
  }
  if (!moved) return;
  pending_cuts_ = std::move(cuts);
  // Counted bodies are exact: take the new cuts at once. Time: only when the time the ranks
  // lost waiting in the last interval exceeds what a rebuild costs; else at the next one.
  force_rebuild_ = balance_.mode == BalanceMode::kBodies || most[0] - mean > most[1];
}

}  // namespace hardrod
