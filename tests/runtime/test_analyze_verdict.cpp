// What `hardrod analyze` says of its input: the MSER-5 cut and its cap, each run's
// equilibration judged from timeseries.csv, and each fit's trust from its chi^2.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "kernels/block_average.hpp"
#include "runtime/analyze_verdict.hpp"

namespace hardrod {
namespace {

namespace fs = std::filesystem;

// S(t) sampled every 0.1 tau: `relax` samples of a decay from 0.9 to 0.75 (equilibration),
// then noise around 0.75 plus `trend` per sample (production starts at `equil`).
std::vector<double> series(int equil, int prod, int relax, double trend, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.004);
  std::vector<double> s;
  for (int k = 0; k < equil + prod; ++k) {
    const double decay = k < relax ? 0.15 * (1.0 - static_cast<double>(k) / relax) : 0.0;
    s.push_back(0.75 + decay + trend * k + noise(rng));
  }
  return s;
}

std::string write_run(const std::string &name, const std::vector<double> &s, int equil) {
  const fs::path dir = fs::temp_directory_path() / ("hardrod-verdict-" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream f(dir / "timeseries.csv");
  f << "step,time,phase,order_parameter,pressure_star\n";
  for (int k = 0; k < static_cast<int>(s.size()); ++k)
    f << k * 50 << "," << 0.1 * k << "," << (k < equil ? "equilibration" : "production") << ","
      << s[k] << ",6.0\n";
  return dir.string();
}

TEST(Mser, CutsATransientAndTellsACapFromACut) {
  const MserCut transient = mser_cut(series(400, 600, 100, 0.0, 1));
  EXPECT_FALSE(transient.at_cap);
  EXPECT_GE(transient.samples, 60);
  EXPECT_LE(transient.samples, 150);
  std::vector<double> ramp;
  for (int k = 0; k < 1000; ++k) ramp.push_back(1.0 - 1e-4 * k);  // never settles
  const MserCut capped = mser_cut(ramp);
  EXPECT_TRUE(capped.at_cap);
  EXPECT_EQ(capped.samples, 500);
  EXPECT_FALSE(mser_cut({1.0, 2.0, 3.0}).at_cap);  // too short to search
}

TEST(AnalyzeVerdict, ARelaxedRunIsEquilibrated) {
  const auto run = judge_run(write_run("relaxed", series(1000, 3000, 200, 0.0, 2), 1000), {});
  EXPECT_TRUE(run["equilibrated"].get<bool>()) << run.dump(2);
  EXPECT_FALSE(run["cut_at_cap"].get<bool>());
  EXPECT_LT(run["mser_cut_tau"].get<double>(), run["production_starts_tau"].get<double>());
}

TEST(AnalyzeVerdict, SFallingThroughProductionIsNotEquilibrated) {
  // Production still falls, 0.77 -> 0.73 as in a short run from the lattice.
  const auto run = judge_run(write_run("falling", series(300, 500, 300, -0.04 / 800, 3), 300), {});
  EXPECT_FALSE(run["equilibrated"].get<bool>());
  const std::string why = run["reasons"].dump();
  EXPECT_NE(why.find("drifts"), std::string::npos) << why;
  EXPECT_NE(why.find("cap"), std::string::npos) << why;
}

TEST(AnalyzeVerdict, ARelaxationIntoProductionIsNotEquilibrated) {
  // Settled in its first third of production, so the thirds may agree; the cut says it.
  const auto run = judge_run(write_run("late", series(100, 2000, 400, 0.0, 4), 100), {});
  EXPECT_FALSE(run["equilibrated"].get<bool>());
  EXPECT_NE(run["reasons"].dump().find("after the production"), std::string::npos) << run.dump(2);
}

TEST(AnalyzeVerdict, WithoutTimeseriesTheSummarySays) {
  const fs::path dir = fs::temp_directory_path() / "hardrod-verdict-none";
  fs::remove_all(dir);
  fs::create_directories(dir);
  EXPECT_FALSE(judge_run(dir.string(), {{"equilibrated", false}})["equilibrated"].get<bool>());
  EXPECT_TRUE(judge_run(dir.string(), {{"equilibrated", true}})["equilibrated"].get<bool>());
}

TEST(AnalyzeVerdict, ABrokenTimeseriesNamesFileAndLine) {
  const std::string dir = write_run("broken", series(10, 40, 5, 0.0, 5), 10);
  std::ofstream(fs::path(dir) / "timeseries.csv", std::ios::app) << "9,9.0,production,nan,6.0\n";
  try {
    judge_run(dir, {});
    FAIL() << "a NaN sample was accepted";
  } catch (const std::runtime_error &e) {
    EXPECT_NE(std::string(e.what()).find("timeseries.csv: line 52"), std::string::npos) << e.what();
  }
}

FrankModelFit fit(double chi2) {
  FrankModelFit f;
  f.K1.value = 0.8, f.K2.value = 0.4, f.K3.value = 1.6;
  f.dof_13 = 20, f.dof_23 = 20;
  f.chi2_13 = chi2, f.chi2_23 = chi2;
  return f;
}

TEST(AnalyzeVerdict, AFitIsTrustedOnlyWhenConsistentAndEquilibrated) {
  EXPECT_TRUE(judge_fit(fit(1.1), true)["trusted"].get<bool>());
  EXPECT_TRUE(judge_fit(fit(2.0), true)["trusted"].get<bool>());  // absorbed by the inflation
  EXPECT_FALSE(judge_fit(fit(4.5), true)["trusted"].get<bool>());
  const auto planar = judge_fit(fit(393.0), true);
  EXPECT_FALSE(planar["trusted"].get<bool>());
  EXPECT_NE(planar["reason"].get<std::string>().find("393"), std::string::npos);
  EXPECT_FALSE(judge_fit(fit(1.1), false)["trusted"].get<bool>());
  FrankModelFit undetermined = fit(1.0);
  undetermined.K2.value = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(judge_fit(undetermined, true)["trusted"].get<bool>());
  EXPECT_NEAR(chi2_dof_limit(40), 3.0 + 3.0 * std::sqrt(0.05), 1e-12);
}

// The slowest mode's verdict from its numbers: the relaxation 1 - exp(-2 t / lifetime), the
// production against the lifetime, and no judgement where the start is a file.
TEST(AnalyzeVerdict, DirectorModesRelaxedOnlyAfterLongEnoughEquilibration) {
  FrankSlowestMode m;
  m.component = 2, m.E = 0.0048, m.k1sq = 0.0121, m.k3sq = 0.0;
  m.lifetime_samples = 2800.0, m.replica_samples = 4000.0;  // 280 tau, 400 tau at 0.1 tau
  const auto paper = judge_director_modes(m, 0.1, 150.0);
  EXPECT_FALSE(paper["relaxed"].get<bool>());
  EXPECT_NEAR(paper["relaxed_fraction"].get<double>(), 1.0 - std::exp(-300.0 / 280.0), 1e-12);
  EXPECT_NE(paper["reason"].get<std::string>().find("at least 419 tau"), std::string::npos)
      << paper["reason"];
  const auto long_run = judge_director_modes(m, 0.1, 600.0);
  EXPECT_TRUE(long_run["relaxed"].get<bool>()) << long_run.dump();
  EXPECT_TRUE(long_run["judged"].get<bool>());
  EXPECT_FALSE(judge_fit(fit(1.1), true, paper)["trusted"].get<bool>());
  EXPECT_TRUE(judge_fit(fit(1.1), true, long_run)["trusted"].get<bool>());

  const auto from_file = judge_director_modes(m, 0.1, std::numeric_limits<double>::quiet_NaN());
  EXPECT_FALSE(from_file["judged"].get<bool>());
  EXPECT_TRUE(from_file["relaxed"].get<bool>());
  m.outlives_replicas = true;  // a production shorter than the mode: never relaxed
  const auto outlived = judge_director_modes(m, 0.1, std::numeric_limits<double>::quiet_NaN());
  EXPECT_FALSE(outlived["relaxed"].get<bool>());
  EXPECT_NE(outlived["reason"].get<std::string>().find("cannot average"), std::string::npos);
  EXPECT_FALSE(judge_director_modes(FrankSlowestMode{}, 0.1, 600.0)["judged"].get<bool>());
}

}  // namespace
}  // namespace hardrod
