// Blocking analysis of a time series: Flyvbjerg-Petersen levels, Jonsson's choice of the
// plateau level, lag-1 bias correction, minimum block count for convergence; the rule and
// the references are in block_average.hpp. Serial by design (1e5 samples at most); plain
// double sums in a fixed order, so the result is deterministic.
#include "kernels/block_average.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>

namespace hardrod {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// Blocks needed at the chosen level for a converged estimate, and for a level to enter the
// fallback maximum. With 64 blocks the error itself is known to 9 %, and the correlation
// test has the power to see what is left: with 32, most AR(1) series only 20 correlation
// times long passed it, with errors 30-40 % too small.
constexpr std::size_t kConvergedBlocks = 64;
constexpr std::size_t kFallbackBlocks = 8;

struct Level {
  std::size_t blocks;  // n_l
  double error;        // e_l, naive standard error of the mean at this level
  double lag1;         // r_l, lag-1 autocorrelation of the block means (0 if they are equal)
};

// 99 % quantile of chi^2 with k degrees of freedom. Table for k <= 30 (a series of 2^30
// samples); Wilson-Hilferty beyond (relative error < 1e-3 there).
double chi2_quantile_99(std::size_t k) {
  static constexpr std::array<double, 30> kTable = {
      6.634897,  9.210340,  11.344867, 13.276704, 15.086272, 16.811894, 18.475307, 20.090235,
      21.665994, 23.209251, 24.724970, 26.216967, 27.688250, 29.141238, 30.577914, 31.999927,
      33.408664, 34.805306, 36.190869, 37.566235, 38.932173, 40.289360, 41.638398, 42.979820,
      44.314105, 45.641683, 46.962942, 48.278236, 49.587884, 50.892181};
  if (k >= 1 && k <= kTable.size()) return kTable[k - 1];
  const double z = 2.3263478740408408;  // standard normal 99 % quantile
  const double a = 2.0 / (9.0 * static_cast<double>(k));
  return static_cast<double>(k) * std::pow(1.0 - a + z * std::sqrt(a), 3);
}

// All blocking levels that have at least two blocks.
std::vector<Level> blocking_levels(std::vector<double> blocks) {
  std::vector<Level> levels;
  while (blocks.size() >= 2) {
    const std::size_t n = blocks.size();
    double sum = 0.0;
    for (double y : blocks) sum += y;
    const double mean = sum / static_cast<double>(n);
    double sq = 0.0, lag = 0.0;
    for (std::size_t i = 0; i < n; ++i) {
      const double d = blocks[i] - mean;
      sq += d * d;
      if (i + 1 < n) lag += d * (blocks[i + 1] - mean);
    }
    const double nd = static_cast<double>(n);
    levels.push_back({n, std::sqrt(sq / (nd * (nd - 1.0))), sq > 0.0 ? lag / sq : 0.0});
    for (std::size_t i = 0; i < n / 2; ++i) blocks[i] = 0.5 * (blocks[2 * i] + blocks[2 * i + 1]);
    blocks.resize(n / 2);
  }
  return levels;
}

// Jonsson's test: the first level from which on no lag-1 correlation is detected.
std::size_t decorrelated_level(const std::vector<Level> &levels) {
  const std::size_t count = levels.size();
  std::vector<double> tail(count + 1, 0.0);  // tail[l] = M_l = sum_{k >= l} n_k r_k^2
  for (std::size_t k = count; k-- > 0;)
    tail[k] = tail[k + 1] + static_cast<double>(levels[k].blocks) * levels[k].lag1 * levels[k].lag1;
  for (std::size_t l = 0; l < count; ++l)
    if (tail[l] < chi2_quantile_99(count - l)) return l;
  return count - 1;
}

}  // namespace

Estimate block_average(const std::vector<double> &series) {
  Estimate est;
  est.samples = static_cast<long long>(series.size());
  if (series.empty()) {
    est.error = kInf;
    return est;
  }
  if (!std::all_of(series.begin(), series.end(), [](double v) { return std::isfinite(v); })) {
    est.mean = est.error = kNaN;
    return est;
  }
  double sum = 0.0;
  for (double v : series) sum += v;
  est.mean = sum / static_cast<double>(series.size());
  if (series.size() == 1) {
    est.error = kInf;
    return est;
  }
  const auto [lo, hi] = std::minmax_element(series.begin(), series.end());
  if (*lo == *hi) {
    est.mean = *lo;  // exact, where sum / n may be off by an ulp
    est.error = 0.0;
    est.converged = true;
    return est;
  }

  const std::vector<Level> levels = blocking_levels(series);
  const std::size_t chosen = decorrelated_level(levels);
  const Level &at = levels[chosen];
  const double lag1_unbiased = at.lag1 + 1.0 / static_cast<double>(at.blocks);
  const double corrected = at.error * std::sqrt(std::max(0.0, 1.0 + 2.0 * lag1_unbiased));
  if (at.blocks >= kConvergedBlocks) {
    est.error = corrected;
    est.block_size = 1LL << chosen;
    est.converged = true;
    return est;
  }

  // Too few decorrelated blocks: the largest error over levels that still have a few.
  std::size_t worst = 0;
  for (std::size_t l = 1; l < levels.size(); ++l)
    if (levels[l].blocks >= kFallbackBlocks && levels[l].error > levels[worst].error) worst = l;
  est.error = levels[worst].error;
  est.block_size = 1LL << worst;
  return est;
}

EquilibrationCheck check_equilibration(const std::vector<double> &series) {
  constexpr std::size_t kMinSamples = 16;
  const std::size_t third = series.size() / 3;
  const auto begin = series.begin();
  const Estimate first = block_average(std::vector<double>(begin, begin + third));
  const Estimate last = block_average(std::vector<double>(series.end() - third, series.end()));
  EquilibrationCheck check;
  check.first_mean = first.mean;
  check.first_error = first.error;
  check.last_mean = last.mean;
  check.last_error = last.error;
  const double tolerance = 3.0 * std::hypot(first.error, last.error);
  // Written so that NaN anywhere gives "not equilibrated".
  check.equilibrated = series.size() >= kMinSamples && first.converged && last.converged &&
                       std::fabs(first.mean - last.mean) <= tolerance;
  return check;
}

MserCut mser_cut(const std::vector<double> &series, int batch) {
  const std::size_t m = series.size() / static_cast<std::size_t>(batch);
  if (m < 8) return {};
  std::vector<double> y(m, 0.0);
  for (std::size_t i = 0; i < m; ++i) {
    for (int j = 0; j < batch; ++j) y[i] += series[i * batch + j];
    y[i] /= batch;
  }
  double best = 0.0;
  std::size_t best_d = 0;
  for (std::size_t d = 0; d <= m / 2; ++d) {
    const double n = static_cast<double>(m - d);
    double mean = 0.0;
    for (std::size_t i = d; i < m; ++i) mean += y[i];
    mean /= n;
    double ss = 0.0;
    for (std::size_t i = d; i < m; ++i) ss += (y[i] - mean) * (y[i] - mean);
    const double score = ss / (n * n);
    if (d == 0 || score < best) best = score, best_d = d;
  }
  return {static_cast<long long>(best_d) * batch, best_d == m / 2};
}

}  // namespace hardrod
