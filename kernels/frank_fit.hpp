// Frank elastic constants from FrankAccumulator data (SPEC.md section 5; seed paper, Frank
// constants): per (k1^2, k3^2) bin E_m3 = (9/4) <S^2> V kT / <|Qk_m3|^2>, m = 1, 2, then
// (a) the plane E_m3 = K_m k1^2 + K3 k3^2 over bins with k1^2, k3^2 < 0.1 and (b) the cubic
// sum_{1 <= i+j; i, j <= 3} a_ij k1^2i k3^2j over all bins; K_m = a_10, K3 = a_01. With kT = 1
// these are K* = beta D K. Errors: spread over independent runs, or a delete-one-block
// jackknife within one run. Serial and deterministic (bins, not bodies: milliseconds).
#pragma once

#include <array>
#include <limits>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "kernels/fourier_order_tensor.hpp"

namespace hardrod {

struct FrankFitOptions {
  double kT = 1.0;
  double planar_max_k2 = 0.1;  // plane: bins whose mean k1^2 and k3^2 are both below this
  double cubic_max_k2 = std::numeric_limits<double>::infinity();  // cubic: likewise (all)
  // Bins with fewer k vectors are skipped: E ~ 1/<|Q|^2> of an exponential variable is
  // heavy-tailed and its own error estimate unreliable for small counts.
  long long min_bin_count = 20;
  // Subtract the uncorrelated-rod (i = j) part of <|Qk_m3|^2>, (9/4)(V/N)^2 sum_i
  // (e_i.e_m)^2 (e_i.n)^2, a k-independent white background from molecular disorder.
  // Off by default: the paper's estimator. See frank_fit.cpp for when it helps.
  bool subtract_self_term = false;
  // Weighted least squares with weight 1 / (E_model rel)^2, rel = sqrt(cv^2 / count) the
  // relative error of the bin's <|Q|^2> (cv^2 pooled over bins, 1 for Gaussian modes) and
  // E_model the previous iteration's fit (the data on the first), so that no bin's weight
  // follows its own noise. The iterations also correct each bin for its finite width.
  int reweighting_iterations = 4;
};

struct FrankEstimate {
  double value = std::numeric_limits<double>::quiet_NaN();
  double error = std::numeric_limits<double>::quiet_NaN();
};

// One model (plane or cubic) fitted to E_13 and E_23.
struct FrankModelFit {
  FrankEstimate K1, K2;  // from E_13 and E_23
  FrankEstimate K3;      // inverse-variance weighted mean of the two below
  FrankEstimate K3_13, K3_23;
  int bins_13 = 0, bins_23 = 0;                               // bins in the fit (merged data)
  double chi2_13 = std::numeric_limits<double>::quiet_NaN();  // per degree of freedom
  double chi2_23 = std::numeric_limits<double>::quiet_NaN();
  // The central fits as terms (i, j, a_ij): E_m3 = sum a_ij (k1^2)^i (k3^2)^j, for plots.
  std::vector<std::array<double, 3>> terms_13, terms_23;
};

// One bin of E_m3 from the merged data, for plots (paper's figures of E_13, E_23).
struct FrankBinE {
  double k1sq = 0, k3sq = 0;  // bin means
  double E = 0, error = 0;    // error from the spread of |Q_m3|^2 within the bin
  long long count = 0;
};

struct FrankResult {
  FrankModelFit planar, cubic;
  std::vector<FrankBinE> E13, E23;
  double mean_S2 = std::numeric_limits<double>::quiet_NaN();
  double kT = 1.0;                    // as fitted (FrankFitOptions)
  bool self_term_subtracted = false;  // as fitted (FrankFitOptions)
  long long samples = 0;
  int runs = 0;
  int replicas = 0;          // runs, or blocks of the single run, the errors come from
  std::string error_method;  // "spread over runs / sqrt(runs)", "jackknife over blocks", "none"
};

// Central values from all runs merged (operator+=, which checks that box, N, kmax and bin
// width agree). Errors: with >= 2 runs, standard deviation of the per-run values /
// sqrt(runs); with one run of >= 2 blocks, delete-one-block jackknife; else NaN. A fit
// with no more bins than parameters gives NaN. Throws std::invalid_argument for no runs.
FrankResult fit_frank(const std::vector<FrankAccumulator> &runs,
                      const FrankFitOptions &options = {});

nlohmann::json to_json(const FrankResult &result);  // NaN written as null

}  // namespace hardrod
