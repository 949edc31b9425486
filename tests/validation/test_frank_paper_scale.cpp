// The Frank-constant chain at the paper's scale (label "long", ~minutes): N = 18432 rods in the
// paper's 57 D box with the paper's kmax = 10, so that every fit sees its whole k range, and
// the everyday box (N = 2304, kmax 6) with the same prescribed field: both must recover K1, K2,
// K3 with the estimators docs/frank.md calls unbiased, and agree with each other.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <tuple>

#include "tests/synthetic_nematic.hpp"

namespace hardrod {
namespace {

using namespace synthetic;

void expect_unbiased(const char *box, const FrankResult &background, const FrankResult &subtracted,
                     const SyntheticNematic &s) {
  std::printf("%s: S = %.4f, %lld samples, %s (%d replicas)\n", box, std::sqrt(background.mean_S2),
              background.samples, background.error_method.c_str(), background.replicas);
  report("background (b fitted)", background.background);
  report("plane, self term subtracted", subtracted.planar);
  report("cubic, self term subtracted", subtracted.cubic);
  report("cubic, paper's (white background in)", background.cubic);
  report("plane, paper's (white background in)", background.planar);
  for (const auto &[name, f] : {std::pair{"background", &background.background},
                                std::pair{"subtracted plane", &subtracted.planar}}) {
    SCOPED_TRACE(std::string(box) + " " + name);
    expect_recovered("K1", f->K1, s.K1, 0.3, 3.0);
    expect_recovered("K2", f->K2, s.K2, 0.3, 3.0);
    expect_recovered("K3", f->K3, s.K3, 0.3, 3.0);
    // chi^2/dof near 1: the errors are right (the plane in the everyday box has ~10 bins per
    // fit, so its chi^2/dof scatters by ~0.5).
    EXPECT_LT(f->chi2_dof(), 3.0);
    EXPECT_GT(f->chi2_dof(), 0.3);
  }
}

TEST(FrankPaperScale, BothBoxesRecoverThePrescribedConstantsAndAgree) {
  SyntheticNematic large, small = everyday_box();
  large.kmax = 10, small.kmax = 6;
  large.tau0 = small.tau0 = 0.8;
  const auto large_runs = correlated_runs(large, 6, 40, 101);
  const auto small_runs = correlated_runs(small, 6, 150, 102);
  const FrankResult lb = fit_frank(large_runs, fit_options(false)),
                    ls = fit_frank(large_runs, fit_options(true));
  const FrankResult sb = fit_frank(small_runs, fit_options(false)),
                    ss = fit_frank(small_runs, fit_options(true));
  expect_unbiased("N = 18432, kmax 10", lb, ls, large);
  expect_unbiased("N = 2304, kmax 6", sb, ss, small);
  EXPECT_GT(lb.cubic.bins_13, 1000);  // the whole cubic range is sampled in the paper's box
  for (const auto &[name, a, b] : {std::tuple{"K1", lb.background.K1, sb.background.K1},
                                   std::tuple{"K2", lb.background.K2, sb.background.K2},
                                   std::tuple{"K3", lb.background.K3, sb.background.K3}})
    EXPECT_LT(std::fabs(a.value - b.value), 3.0 * std::hypot(a.error, b.error)) << name;
}

}  // namespace
}  // namespace hardrod
