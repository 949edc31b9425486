// Frank elastic constants from FrankAccumulator data (docs/frank.md). Per (k1^2, k3^2) bin,
// E_m3 = (9/4) <S^2> V kT / <|Qk_m3|^2>, m = 1, 2; the theory says E_m3 = K_m k1^2 + K3 k3^2
// at small k. Three estimators:
//  planar      the plane E = K_m k1^2 + K3 k3^2 over bins with k1^2, k3^2 < 0.1 D^-2 (the
//              paper's). Reads a secant of E_obs = E / (1 + b E), where b is the white
//              background of uncorrelated molecular disorder: biased low by ~ b E there.
//  cubic       sum_{1 <= i+j; i, j <= 3} a_ij k1^2i k3^2j over k1^2 <= 2, k3^2 <= 1 D^-2 (the
//              paper's range, the same in every box); K_m = a_10, K3 = a_01. The higher terms
//              absorb the background's -b E^2 + b^2 E^3.
//  background  E_obs = P / (1 + b P) over the cubic's range, P = K_m k1^2 + K3 k3^2 + the
//              three quadratic terms, with b >= 0 fitted: the white background as a parameter
//              (it sets the saturation of E at large k, which no polynomial term mimics).
// With kT = 1 these are K* = beta D K.
//
// Errors. A bin's <|Q|^2> is a mean over samples that are correlated in time: a director mode
// lives for ~ gamma / (K k^2), tens of tau at the smallest k, against a sample every 0.02 tau.
// Its variance is phi_b <|Q|^2>^2 / n_b (n_b = k vectors x samples), and the inflation phi_b is
// measured from the spread of the bin between replicas (independent runs, or, for one run,
// eight consecutive stretches of it) and smoothed over bins by the model phi = g0 + g1 / E,
// since the relaxation time goes as 1 / E. Fits are weighted least squares with these
// variances; a fit's error is its covariance, scaled up by sqrt(chi^2/dof) when that exceeds 1;
// the quoted error is the larger of that and the spread of the replicas' own fits (three or
// more replicas). chi^2/dof near 1 says the errors and the model fit. Serial and
// deterministic (bins, not bodies: milliseconds). The result as JSON: runtime/frank_io.hpp.
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include "kernels/fourier_order_tensor.hpp"

namespace hardrod {

struct FrankFitOptions {
  double kT = 1.0;
  double planar_max_k2 = 0.1;   // planar fit: bin means k1^2, k3^2 below this
  double cubic_max_k1sq = 2.0;  // cubic and background fits: bin mean k1^2 at most this (D^-2)
  double cubic_max_k3sq = 1.0;  // and k3^2 at most this
  // Bins with fewer k vectors are skipped: E ~ 1/<|Q|^2> of an exponential variable is
  // heavy-tailed for small counts.
  long long min_bin_count = 20;
  // Bins whose relative error exceeds this (fewer than 1/x^2 effective samples: the slow,
  // long-wavelength modes of short runs) are skipped for the same reason.
  double max_bin_relative_error = 0.5;
  // Subtract the uncorrelated-rod (i = j) part of <|Qk_m3|^2>, (9/4)(V/N)^2 sum_i
  // (e_i.e_m)^2 (e_i.n)^2. Bins where it is more than half the signal are then left out (their
  // E would be mostly noise). Off by default: in a liquid the background is not only the self
  // term, so the background estimator fits it instead.
  bool subtract_self_term = false;
  int reweighting_iterations = 4;  // weights from the previous fit's E (not each bin's own)
  int replica_groups = 8;          // one run: consecutive stretches used as replicas
};

struct FrankEstimate {
  double value = std::numeric_limits<double>::quiet_NaN();
  // The error quoted: fit_error, or the replicas' spread where that is larger (three or more
  // replicas): the conservative one of two honest estimates, as for S and P*.
  double error = std::numeric_limits<double>::quiet_NaN();
  double spread =
      std::numeric_limits<double>::quiet_NaN();  // standard error from the replicas' fits
  double fit_error = std::numeric_limits<double>::quiet_NaN();  // from the fit (see header)
};

// One model (planar, cubic or background) fitted to E_13 and to E_23.
struct FrankModelFit {
  FrankEstimate K1, K2;  // from E_13 and E_23
  FrankEstimate K3;      // inverse-variance weighted mean of the two below
  FrankEstimate K3_13, K3_23;
  int bins_13 = 0, bins_23 = 0;                               // bins in the fit
  int dof_13 = 0, dof_23 = 0;                                 // bins - parameters
  double chi2_13 = std::numeric_limits<double>::quiet_NaN();  // per degree of freedom
  double chi2_23 = std::numeric_limits<double>::quiet_NaN();
  // The background model's b (NaN for the polynomial models), E_13 and E_23.
  FrankEstimate background_13, background_23;
  // The central fits as terms (i, j, a_ij): P = sum a_ij (k1^2)^i (k3^2)^j, E = P / (1 + b P)
  // with b = 0 for the polynomial models. For plots.
  std::vector<std::array<double, 3>> terms_13, terms_23;
  double chi2_dof() const;  // the two fits pooled
};

// One bin of E_m3 from the merged data, for plots (paper's figures of E_13, E_23).
struct FrankBinE {
  double k1sq = 0, k3sq = 0;  // bin means
  double E = 0, error = 0;    // error from the variance model (see header)
  long long count = 0;
  // The bin's own inflation phi from the replicas' spread (NaN with fewer than two)
  double phi = std::numeric_limits<double>::quiet_NaN();
};

// The variance model phi = g0 + g1 / E of one component, fitted to the replicas.
struct FrankVarianceModel {
  double g0 = std::numeric_limits<double>::quiet_NaN();
  double g1 = std::numeric_limits<double>::quiet_NaN();
  int bins = 0;
};

struct FrankResult {
  FrankModelFit planar, cubic, background;
  std::vector<FrankBinE> E13, E23;
  FrankVarianceModel variance_13, variance_23;
  double mean_S2 = std::numeric_limits<double>::quiet_NaN();
  FrankFitOptions options;  // as fitted
  long long samples = 0;
  int runs = 0;
  int replicas = 0;          // runs, or stretches of the single run, the variances come from
  std::string error_method;  // how the bin variances were measured
};

// The slowest director mode among a result's bins (the smallest E of E13 and E23) and its
// lifetime from the bins' inflation: amplitudes that decorrelate as exp(-t / tau) (tau in
// samples) give a bin's mean over n samples the inflation phi -> coth(1 / tau) for n >> tau,
// and -> n once tau outlives the replicas (then only tau >= n is known: outlives_replicas).
// Relaxing from an aligned start, such a mode's variance reaches 1 - exp(-2 t / tau) of its
// equilibrium value by time t. NaN fields where there are no bins or no replicas.
struct FrankSlowestMode {
  double E = std::numeric_limits<double>::quiet_NaN();
  double k1sq = std::numeric_limits<double>::quiet_NaN();
  double k3sq = std::numeric_limits<double>::quiet_NaN();
  int component = 0;  // 1: E13, 2: E23
  double lifetime_samples = std::numeric_limits<double>::quiet_NaN();
  double replica_samples = std::numeric_limits<double>::quiet_NaN();  // samples per replica
  bool outlives_replicas = false;  // lifetime_samples is then replica_samples, a lower bound
};
FrankSlowestMode slowest_mode(const FrankResult &r);

// Central values from all runs merged (operator+=, which checks that box, N, kmax and bin
// width agree). A fit with no more bins than parameters, or whose K is not positive and
// finite, gives NaN. Throws std::invalid_argument for no runs.
FrankResult fit_frank(const std::vector<FrankAccumulator> &runs,
                      const FrankFitOptions &options = {});

}  // namespace hardrod
