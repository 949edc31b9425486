// Error bars for a correlated time series by blocking (Flyvbjerg & Petersen, J. Chem. Phys.
// 91, 461 (1989)); the plateau is located by the lag-1 autocorrelation test of Jonsson
// (Phys. Rev. E 98, 043304 (2018)). docs/physics.md section 5: every reported number carries an
// error estimate and an equilibration verdict. Input: one sample per sampling interval, in
// time order. Serial and deterministic (the series is tiny next to the simulation).
#pragma once

#include <vector>

namespace hardrod {

struct Estimate {
  double mean = 0.0;         // mean of all samples
  double error = 0.0;        // standard error of the mean
  long long samples = 0;     // length of the series
  long long block_size = 1;  // samples per block at the level the error was taken from
  bool converged = false;    // plateau found at a level that still has >= 64 blocks
};

// Standard error of the mean of a correlated series.
//
// Blocking: level 0 is the series; level l+1 averages neighbouring pairs of level l (a
// trailing odd block is dropped). At each level with n blocks y_i of mean m:
//   e_l = sqrt(sum (y_i - m)^2 / (n (n - 1)))                 naive error of the mean
//   r_l = sum (y_i - m)(y_{i+1} - m) / sum (y_i - m)^2        lag-1 autocorrelation
// e_l rises with l until the blocks are longer than the correlation time, then stays flat
// (the plateau). Its start is found as the first level l from which on the blocks look
// independent: M_l = sum_{k >= l} n_k r_k^2 below the 99 % quantile of chi^2 with
// (levels - l) degrees of freedom (Jonsson's test). Blocks just past the correlation time
// still correlate slightly with their neighbours, which biases e_l low by about r_l, so the
// reported error is e_l sqrt(1 + 2 (r_l + 1/n_l)) (the 1/n_l undoes the bias of r_l itself).
// Converged: that level has >= 64 blocks. Otherwise the series is too short for its
// correlation time (or has a trend), and the error is the largest e_l over levels with
// >= 8 blocks, a conservative bound, with converged = false.
// Edge cases: empty series: samples 0, mean 0, error +inf. One sample: error +inf. Constant
// series: error 0, converged. Any non-finite sample: mean and error NaN, not converged.
Estimate block_average(const std::vector<double> &series);

// Equilibration heuristic: block-average the first and the last third of the series; they
// must agree within 3 combined errors. Also requires >= 16 samples and both estimates
// converged: a transient inflates the unconverged (fallback) error of its third enough to
// hide the shift in the mean. In practice this needs >= 192 samples and a correlation time
// well below a third of the series.
struct EquilibrationCheck {
  bool equilibrated = false;
  double first_mean = 0.0, first_error = 0.0;
  double last_mean = 0.0, last_error = 0.0;
};

EquilibrationCheck check_equilibration(const std::vector<double> &series);

// MSER-5 (White, Simulation 69, 323 (1997)): the cut d, in batches of `batch` samples and at
// most half the series, that minimises the squared standard error of the rest, var / (n - d).
// A cut at that cap says the series never settled over its first half, not where it did.
// Below 8 batches: cut 0, not at the cap.
struct MserCut {
  long long samples = 0;  // samples to drop
  bool at_cap = false;
};

MserCut mser_cut(const std::vector<double> &series, int batch = 5);

}  // namespace hardrod
