// Acceptance tests of the Frank-constant chain (fourier_order_tensor -> FrankAccumulator ->
// fit_frank) on synthetic nematics with prescribed K1, K2, K3 (tests/synthetic_nematic.hpp),
// in the everyday box (N = 2304) and the paper's (N = 18432, planar range only: the full range
// at this size is tests/validation/test_frank_paper_scale.cpp, label "long").
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "tests/synthetic_nematic.hpp"

namespace hardrod {
namespace {

using namespace synthetic;

FrankAccumulator merge(const std::vector<FrankAccumulator> &runs) {
  FrankAccumulator m = runs.front();
  for (size_t r = 1; r < runs.size(); ++r) m += runs[r];
  return m;
}

// The estimators that are unbiased on these configurations (their background is exactly the
// self term): the background fit, and the plane with the self term subtracted.
struct Unbiased {
  FrankResult background, subtracted;
};

Unbiased fits(const std::vector<FrankAccumulator> &runs) {
  return {fit_frank(runs, fit_options(false)), fit_frank(runs, fit_options(true))};
}

void expect_all_recovered(const char *box, const Unbiased &u, const SyntheticNematic &s) {
  std::printf("%s: S = %.4f, %lld samples, %s (%d replicas)\n", box,
              std::sqrt(u.background.mean_S2), u.background.samples,
              u.background.error_method.c_str(), u.background.replicas);
  report("background (b fitted)", u.background.background);
  std::printf(
      "  %-34s b13 %.3f +- %.3f  b23 %.3f +- %.3f\n", "",
      u.background.background.background_13.value, u.background.background.background_13.error,
      u.background.background.background_23.value, u.background.background.background_23.error);
  report("cubic, paper's", u.background.cubic);
  report("cubic, self term subtracted", u.subtracted.cubic);
  report("plane, self term subtracted", u.subtracted.planar);
  report("plane (paper's, biased)", u.background.planar);
  for (const auto &[name, f] : {std::pair{"background", &u.background.background},
                                std::pair{"subtracted plane", &u.subtracted.planar}}) {
    SCOPED_TRACE(std::string(box) + " " + name);
    expect_recovered("K1", f->K1, s.K1, 0.3, 3.0);
    expect_recovered("K2", f->K2, s.K2, 0.3, 3.0);
    expect_recovered("K3", f->K3, s.K3, 0.3, 3.0);
    EXPECT_LT(f->chi2_dof(), 2.0);
    EXPECT_GT(f->chi2_dof(), 0.3);
  }
  // The white background of the paper's plane: ~bE too low, and chi^2 does not see it at this
  // precision, which is why the plane is not the default.
  EXPECT_LT(u.background.planar.K3.value, 0.9 * s.K3);
}

// THE acceptance test: six independent runs per box whose director modes are correlated
// between samples as in a simulation (tau_k = 0.8 / E_k samples: up to ~40 samples in the
// everyday box, ~160 in the paper's). One TEST on purpose: ctest runs every TEST in its own
// process, so the checks that share these configurations share one TEST.
TEST(FrankSynthetic, RecoversPrescribedConstantsInBothBoxesWithHonestErrors) {
  SyntheticNematic small = everyday_box(), large;
  small.kmax = 6, large.kmax = 4;
  small.tau0 = large.tau0 = 0.8;
  const auto small_runs = correlated_runs(small, 6, 150, 11);
  const auto large_runs = correlated_runs(large, 6, 40, 12);
  const Unbiased s = fits(small_runs), l = fits(large_runs);
  expect_all_recovered("N = 2304", s, small);
  expect_all_recovered("N = 18432", l, large);

  // The two boxes agree within their combined errors (background estimator).
  for (const auto &[name, a, b] :
       {std::tuple{"K1", s.background.background.K1, l.background.background.K1},
        std::tuple{"K2", s.background.background.K2, l.background.background.K2},
        std::tuple{"K3", s.background.background.K3, l.background.background.K3}})
    EXPECT_LT(std::fabs(a.value - b.value), 3.0 * std::hypot(a.error, b.error)) << name;

  // Honest errors: the slow modes make the bins' variances larger than independent samples
  // would (g1 > 0 in phi = g0 + g1 / E), the fit's errors agree with the spread of the six
  // runs' own fits (itself known to ~30 %), and treating the samples as independent (the
  // must-fail case: one merged run, no replicas) gives errors at least 1.5x too small.
  EXPECT_GT(s.background.variance_23.g1, 0.0);
  const FrankModelFit &f = s.subtracted.planar;
  for (const auto &[name, e] :
       {std::pair{"K1", f.K1}, std::pair{"K2", f.K2}, std::pair{"K3", f.K3}}) {
    EXPECT_GT(e.spread, 0.4 * e.fit_error) << name;
    EXPECT_LT(e.spread, 2.5 * e.fit_error) << name;
    EXPECT_EQ(e.error, std::max(e.fit_error, e.spread)) << name;
  }
  FrankFitOptions naive = fit_options(true);
  naive.replica_groups = 1;
  const FrankResult independent = fit_frank({merge(small_runs)}, naive);
  report("plane, subtracted, samples as independent", independent.planar);
  EXPECT_LT(independent.planar.K2.error, f.K2.fit_error / 1.5);
  EXPECT_EQ(independent.replicas, 0);
}

// Negative control: the same configurations told S = 1 in the normalisation instead of the
// measured S must fail the recovery that the right normalisation passes: every K scales by
// 1 / <S^2> (~2 here), and the check must see it.
TEST(FrankSynthetic, NegativeControlBrokenNormalisationFailsTheRecovery) {
  SyntheticNematic small = everyday_box();
  small.kmax = 6;
  const Box box{{small.side, small.side, small.side}};
  FrankAccumulator right(box, 2304, small.kmax, block_config());
  FrankAccumulator broken(box, 2304, small.kmax, block_config());
  accumulate(small, 60, 5, right, &broken);
  const FrankResult r = fit_frank({right}, fit_options(true));
  const FrankResult b = fit_frank({broken}, fit_options(true));
  report("plane, subtracted, S measured", r.planar);
  report("plane, subtracted, S = 1 (broken)", b.planar);
  const auto recovered = [&](double value, double want) {
    return std::fabs(value - want) <= 0.3 * want;
  };
  EXPECT_TRUE(recovered(r.planar.K3.value, small.K3)) << r.planar.K3.value;
  EXPECT_FALSE(recovered(b.planar.K3.value, small.K3)) << b.planar.K3.value;
  EXPECT_FALSE(recovered(b.planar.K2.value, small.K2)) << b.planar.K2.value;
  EXPECT_NEAR(b.planar.K3.value / r.planar.K3.value, 1.0 / r.mean_S2, 0.05 / r.mean_S2);
}

// The cubic over the paper's range in the everyday box (kmax = 6 reaches k3^2 = 1.2): the
// range, not the box, decides the fit.
TEST(FrankSynthetic, CubicOverThePapersRangeInTheEverydayBox) {
  SyntheticNematic s = everyday_box();
  s.kmax = 6;
  const auto runs = correlated_runs(s, 4, 60, 21);
  const FrankResult r = fit_frank(runs, fit_options(true));
  report("cubic, self term subtracted", r.cubic);
  EXPECT_GT(r.cubic.bins_13, 30);
  // Few k3 values fit in this box (k3^2 = 0, 0.05, 0.19, 0.44, 0.78): K3 is poorly determined,
  // and says so (an error of at least a quarter of the value), within its error.
  expect_recovered("cubic K1", r.cubic.K1, s.K1, 0.3, 3.0);
  expect_recovered("cubic K2", r.cubic.K2, s.K2, 0.3, 3.0);
  expect_recovered("cubic K3", r.cubic.K3, s.K3, 2.0, 3.0);
  EXPECT_GT(r.cubic.K3.error, 0.25 * r.cubic.K3.value);
  // The range is an option: all bins (to kmax) is a different fit. (Without the subtraction:
  // with it, bins whose self term exceeds half the signal are left out, which at large k here
  // are those beyond the range.)
  FrankFitOptions wide = fit_options(false);
  wide.cubic_max_k1sq = wide.cubic_max_k3sq = 100.0;
  EXPECT_GT(fit_frank(runs, wide).cubic.bins_13, fit_frank(runs, fit_options(false)).cubic.bins_13);
}

// Whatever the data, every estimate is either null (NaN) or positive with a positive error.
TEST(FrankFit, EstimatesArePositiveWithAnErrorOrNotDetermined) {
  SyntheticNematic s = everyday_box();
  s.kmax = 6;
  for (int samples : {1, 3, 12}) {
    const auto runs = correlated_runs(s, 2, samples, 31);
    for (bool subtract : {false, true}) {
      const FrankResult r = fit_frank(runs, fit_options(subtract));
      for (const FrankModelFit *f : {&r.planar, &r.cubic, &r.background})
        for (const FrankEstimate &e : {f->K1, f->K2, f->K3, f->K3_13, f->K3_23}) {
          if (std::isnan(e.value)) continue;
          EXPECT_GT(e.value, 0.0);
          EXPECT_TRUE(std::isfinite(e.error) && e.error > 0.0) << samples << " samples";
        }
    }
  }
}

// Must-fail check: with splay and twist swapped in the generator the fit must follow.
TEST(FrankSynthetic, SwappedSplayAndTwistConstantsAreFollowed) {
  SyntheticNematic s;
  std::swap(s.K1, s.K2);
  FrankAccumulator acc(Box{{s.side, s.side, s.side}}, static_cast<long long>(s.bodies), s.kmax,
                       block_config());
  accumulate(s, 160, 424242, acc);
  const FrankResult r = fit_frank({acc}, fit_options(true));
  report("swapped K1, K2: plane, subtracted", r.planar);
  expect_recovered("K1", r.planar.K1, s.K1, 0.1, 3.0);
  expect_recovered("K2", r.planar.K2, s.K2, 0.1, 3.0);
  EXPECT_LT(r.planar.K1.value, r.planar.K2.value);
}

TEST(FrankFit, NoRunsThrowsAndTooLittleDataGivesNaN) {
  EXPECT_THROW(fit_frank({}), std::invalid_argument);
  const FrankAccumulator empty(Box{{10.0, 10.0, 10.0}}, 100, 3);
  const FrankResult r = fit_frank({empty});
  EXPECT_TRUE(std::isnan(r.planar.K1.value) && std::isnan(r.cubic.K3.value));
  EXPECT_TRUE(std::isnan(r.mean_S2));
  EXPECT_EQ(r.error_method, "none");
  EXPECT_TRUE(std::isnan(r.background.K2.value));
  EXPECT_EQ(r.planar.bins_13, 0);
}

}  // namespace
}  // namespace hardrod
