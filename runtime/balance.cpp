#include "runtime/balance.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hardrod {

BalanceMode parse_balance_mode(const std::string &name) {
  if (name == "off") return BalanceMode::kOff;
  if (name == "bodies") return BalanceMode::kBodies;
  if (name == "time") return BalanceMode::kTime;
  throw std::invalid_argument(fmt::format("--balance must be off, bodies or time, got '{}'", name));
}

const char *balance_mode_name(BalanceMode mode) {
  switch (mode) {
    case BalanceMode::kOff:
      return "off";
    case BalanceMode::kBodies:
      return "bodies";
    case BalanceMode::kTime:
      return "time";
  }
  return "off";
}

std::vector<double> balanced_cuts(const std::vector<double> &cuts, const std::vector<double> &loads,
                                  double min_width) {
  const std::size_t n = loads.size();
  if (cuts.size() != n + 1 || n < 2) return cuts;
  double total = 0.0;
  for (double w : loads) {
    if (!(std::isfinite(w) && w >= 0.0)) return cuts;
    total += w;
  }
  if (!(total > 0.0)) return cuts;
  // A slab an earlier step left at the limit may sit a rounding below it: still at the limit.
  const double at_limit = min_width * (1.0 - 1e-9);
  for (std::size_t s = 0; s < n; ++s)
    if (!(cuts[s + 1] - cuts[s] >= at_limit)) return cuts;

  // Cumulative load, piecewise linear between the old cuts: invert it at k total / n.
  std::vector<double> target(cuts);
  double before = 0.0;  // load of the slabs left of slab s
  std::size_t s = 0;
  for (std::size_t k = 1; k < n; ++k) {
    const double want = total * static_cast<double>(k) / static_cast<double>(n);
    while (s + 1 < n && before + loads[s] < want) before += loads[s++];
    const double width = cuts[s + 1] - cuts[s];
    const double f = loads[s] > 0.0 ? std::clamp((want - before) / loads[s], 0.0, 1.0) : 0.5;
    target[k] = cuts[s] + f * width;
  }
  // The largest step towards the target that keeps the widths: they are linear in the step.
  double step = 1.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double w_old = cuts[k + 1] - cuts[k];
    const double w_new = target[k + 1] - target[k];
    if (w_new < min_width)
      step = std::min(step, std::max(0.0, (w_old - min_width) / (w_old - w_new)));
  }
  std::vector<double> out(cuts);
  for (std::size_t k = 1; k < n; ++k) out[k] = cuts[k] + step * (target[k] - cuts[k]);
  for (std::size_t k = 0; k < n; ++k)  // round-off must not break the order
    if (!(out[k + 1] > out[k])) return cuts;
  return out;
}

}  // namespace hardrod
