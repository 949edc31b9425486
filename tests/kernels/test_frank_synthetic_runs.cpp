// The Frank chain on synthetic runs shaped like real ones (tests/synthetic_nematic.hpp): the
// recommended cubic fit where its model holds, a wandering director with mode lifetimes like a
// run's, and an under-relaxed start, whose bias the analysis must flag.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <tuple>
#include <vector>

#include "runtime/analyze_verdict.hpp"
#include "tests/synthetic_nematic.hpp"

namespace hardrod {
namespace {

using namespace synthetic;

// Lifetimes as in a run sampled every 0.5 tau: the everyday box's slowest twist mode
// (E ~ 0.02) lives ~70 tau, 130 samples (docs/validation.md: ~280 tau in the paper's box, of
// four times the area).
constexpr double kRunTau0 = 2.7;
constexpr double kSampleTau = 0.5;

void print_slowest(const char *what, const FrankSlowestMode &m) {
  std::printf(
      "  %s: slowest bin E%d3 = %.4f (k1^2 %.4f, k3^2 %.4f), lifetime %s%.1f samples of "
      "%.0f per replica\n",
      what, m.component, m.E, m.k1sq, m.k3sq, m.outlives_replicas ? ">= " : "", m.lifetime_samples,
      m.replica_samples);
}

// E of the model at a bin's mean wave vector.
double prescribed_E(const SyntheticNematic &s, const FrankSlowestMode &m) {
  return (m.component == 1 ? s.K1 : s.K2) * m.k1sq + s.K3 * m.k3sq;
}

// The recommended fit, asserted (2 sd and 10 %) where its model holds: a background small
// against the director signal (noise 0.05, S ~ 0.87). A white background as large as the
// liquid's self term (noise 0.3) pulls it ~20 % low, which the cubic's terms cannot absorb
// over this range: docs/frank.md says why the liquid's background is not white.
TEST(FrankSyntheticRuns, RecommendedCubicWithinTwoErrorsAndTenPercent) {
  SyntheticNematic s = everyday_box();
  s.kmax = 6, s.tau0 = 0.8, s.noise = 0.05;
  const FrankResult r = fit_frank(correlated_runs(s, 6, 150, 41), fit_options(false));
  report("cubic (recommended), noise 0.05", r.cubic);
  expect_recovered("K1", r.cubic.K1, s.K1, 0.1, 2.0);
  expect_recovered("K2", r.cubic.K2, s.K2, 0.1, 2.0);
  expect_recovered("K3", r.cubic.K3, s.K3, 0.1, 2.0);
  EXPECT_LT(r.cubic.chi2_dof(), 1.5);

  s.noise = 0.3;
  const FrankResult white = fit_frank(correlated_runs(s, 6, 150, 41), fit_options(false));
  report("cubic (recommended), noise 0.3", white.cubic);
  EXPECT_LT(white.cubic.K1.value, 0.9 * s.K1);
}

// A director that wanders by degrees over a run (the analysis measures in each sample's frame)
// and modes that live as in a run (the slowest ~130 samples, against ~2 for the fast ones of
// the tests above): the recommended and the background fit still recover K, their errors are
// honest, and the lifetime the analysis reads from the bins' spread is the prescribed one
// within its uncertainty (a factor 2: six replicas).
TEST(FrankSyntheticRuns, WanderingDirectorWithRunLifetimes) {
  SyntheticNematic s = everyday_box();
  s.kmax = 6, s.tau0 = kRunTau0, s.noise = 0.05, s.director_step = 0.01;
  SyntheticSampler walk(s);
  walk.start(1);
  for (int t = 0; t < 800; ++t) walk.advance();
  const double turned = std::acos(std::fmin(1.0, dot(walk.director(), unit(s.director))));
  std::printf("  director turned %.1f degrees in 800 samples\n", turned * 180.0 / std::numbers::pi);
  EXPECT_GT(turned, 0.05);

  const auto runs = correlated_runs(s, 6, 800, 51);
  const auto halves = runs.front().halves();  // what the analysis compares
  EXPECT_EQ(halves[0].samples(), 400);
  EXPECT_EQ(halves[1].samples(), 400);
  const FrankResult r = fit_frank(runs, fit_options(false));
  report("cubic (recommended)", r.cubic);
  report("background", r.background);
  for (const FrankModelFit *f : {&r.cubic, &r.background}) {
    expect_recovered("K1", f->K1, s.K1, 0.1, 2.0);
    expect_recovered("K2", f->K2, s.K2, 0.1, 2.0);
    expect_recovered("K3", f->K3, s.K3, 0.1, 2.0);
    for (const FrankEstimate *e : {&f->K1, &f->K2, &f->K3}) {
      EXPECT_GT(e->spread, 0.3 * e->fit_error);
      EXPECT_LT(e->spread, 3.0 * e->fit_error);
    }
  }
  const FrankSlowestMode m = slowest_mode(r);
  print_slowest("wandering", m);
  const double prescribed = s.tau0 / prescribed_E(s, m);
  std::printf("  prescribed lifetime %.1f samples\n", prescribed);
  EXPECT_FALSE(m.outlives_replicas);
  EXPECT_GT(m.lifetime_samples, 0.5 * prescribed);
  EXPECT_LT(m.lifetime_samples, 2.0 * prescribed);
  // 800 samples of 0.5 tau after a long equilibration: relaxed.
  const nlohmann::json v = judge_director_modes(m, kSampleTau, 2000 * kSampleTau);
  EXPECT_TRUE(v["relaxed"].get<bool>()) << v.dump();
}

// From the aligned start (every mode amplitude zero), 80 samples of equilibration leave the
// slowest mode at 1 - exp(-2 x 80 / 130) ~ 70 % of its variance: its E reads stiff by ~1/0.7
// (the bias long equilibration removes), and the analysis says so; 600 samples relax it.
// (The lifetime read from runs a fraction of it long is a lower bound: the flag errs lenient
// there, and still fires.)
TEST(FrankSyntheticRuns, UnderRelaxedStartIsBiasedAndFlagged) {
  SyntheticNematic s = everyday_box();
  s.kmax = 6, s.tau0 = kRunTau0, s.noise = 0.05;
  // The under-relaxed runs as short as the paper's production against its slowest mode (a
  // fifth of a lifetime); the relaxed ones long enough to average it.
  for (const auto &[equilibration, runs, samples] :
       {std::tuple{80, 12, 30}, std::tuple{600, 6, 300}}) {
    const FrankResult r =
        fit_frank(correlated_runs(s, runs, samples, 61, 0.0, equilibration), fit_options(false));
    const FrankSlowestMode m = slowest_mode(r);
    std::printf("aligned start, %d samples of equilibration:\n", equilibration);
    report("cubic (recommended)", r.cubic);
    print_slowest("slowest", m);
    const double stiff = m.E / prescribed_E(s, m);
    std::printf("  slowest bin's E / prescribed: %.3f\n", stiff);
    const nlohmann::json v = judge_director_modes(m, kSampleTau, equilibration * kSampleTau);
    std::printf("  verdict: %s\n", v.dump().c_str());
    if (equilibration == 80) {
      EXPECT_GT(stiff, 1.2);
      EXPECT_FALSE(v["relaxed"].get<bool>());
      EXPECT_LT(v["relaxed_fraction"].get<double>(), 0.95);
      EXPECT_NE(v["reason"].get<std::string>().find("read high"), std::string::npos);
    } else {
      EXPECT_LT(std::fabs(stiff - 1.0), 0.12);
      EXPECT_TRUE(v["relaxed"].get<bool>()) << v.dump();
    }
  }
}

}  // namespace
}  // namespace hardrod
