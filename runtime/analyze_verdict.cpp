#include "runtime/analyze_verdict.hpp"

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "kernels/block_average.hpp"

namespace hardrod {

namespace {

namespace fs = std::filesystem;

struct Series {
  std::vector<double> time, s;
  std::vector<bool> production;
};

std::vector<std::string> split(const std::string &line) {
  std::vector<std::string> out;
  std::stringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ',')) out.push_back(cell);
  return out;
}

double number(const std::string &text, const fs::path &path, long long line) {
  try {
    std::size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size() && std::isfinite(v)) return v;
  } catch (const std::exception &) {
  }
  throw std::runtime_error(
      fmt::format("{}: line {}: \"{}\" is not a finite number", path.string(), line, text));
}

// time, phase and order_parameter of every row, found by the header's names.
Series read_series(const fs::path &path, std::ifstream &in) {
  std::string line;
  std::getline(in, line);
  const auto header = split(line);
  int t = -1, phase = -1, s = -1;
  for (int k = 0; k < static_cast<int>(header.size()); ++k) {
    if (header[k] == "time") t = k;
    if (header[k] == "phase") phase = k;
    if (header[k] == "order_parameter") s = k;
  }
  if (t < 0 || phase < 0 || s < 0)
    throw std::runtime_error(fmt::format(
        "{}: the header lacks time, phase or order_parameter (\"{}\")", path.string(), line));
  Series out;
  for (long long n = 2; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    const auto cells = split(line);
    if (static_cast<int>(cells.size()) <= std::max({t, phase, s}))
      throw std::runtime_error(
          fmt::format("{}: line {} has {} columns", path.string(), n, cells.size()));
    out.time.push_back(number(cells[t], path, n));
    out.s.push_back(number(cells[s], path, n));
    out.production.push_back(cells[phase] == "production");
  }
  return out;
}

// The production's thirds: a relaxation still under way moves S between them.
void judge_drift(const std::vector<double> &prod, nlohmann::json &out,
                 std::vector<std::string> &reasons) {
  const EquilibrationCheck c = check_equilibration(prod);
  out["production"] = {{"samples", prod.size()},
                       {"first_third", c.first_mean},
                       {"first_third_error", c.first_error},
                       {"last_third", c.last_mean},
                       {"last_third_error", c.last_error}};
  if (c.equilibrated) return;
  if (prod.size() < 16)
    reasons.push_back(fmt::format("production too short to judge ({} samples of S)", prod.size()));
  else if (std::abs(c.last_mean - c.first_mean) > 3.0 * std::hypot(c.first_error, c.last_error))
    reasons.push_back(fmt::format(
        "S drifts over the production: {:.4f} +/- {:.4f} in its first third, {:.4f} +/- "
        "{:.4f} in its last",
        c.first_mean, c.first_error, c.last_mean, c.last_error));
  else
    reasons.push_back(fmt::format(
        "S's production thirds are too short for S's correlation time ({} samples): the "
        "errors have not converged",
        prod.size()));
}

// MSER-5 over S(t) from the start, where the run holds its equilibration.
void judge_cut(const Series &ts, nlohmann::json &out, std::vector<std::string> &reasons) {
  std::size_t first_prod = 0;
  while (first_prod < ts.production.size() && !ts.production[first_prod]) ++first_prod;
  if (first_prod == 0 || first_prod == ts.production.size()) return;  // no S(t) from the start
  const MserCut cut = mser_cut(ts.s);
  const double t_cut = ts.time[static_cast<std::size_t>(cut.samples)];
  const double t_prod = ts.time[first_prod];
  out["mser_cut_tau"] = t_cut;
  out["cut_at_cap"] = cut.at_cap;
  out["production_starts_tau"] = t_prod;
  if (cut.at_cap)
    reasons.push_back(fmt::format(
        "the MSER-5 cut of S(t) sits at the search's cap ({:g} tau, half the series): S never "
        "settled",
        t_cut));
  else if (static_cast<std::size_t>(cut.samples) > first_prod)
    reasons.push_back(fmt::format(
        "the MSER-5 cut of S(t) at {:g} tau falls after the production's start at {:g} tau", t_cut,
        t_prod));
}

}  // namespace

nlohmann::json judge_run(const std::string &dir, const nlohmann::json &summary) {
  nlohmann::json out{{"run", dir}};
  std::vector<std::string> reasons;
  const fs::path path = fs::path(dir) / "timeseries.csv";
  std::ifstream in(path);
  if (!in) {
    const bool eq = summary.value("equilibrated", false);
    out["judged_from"] = "summary.json (no timeseries.csv)";
    if (!eq) reasons.push_back("summary.json says the run is not equilibrated");
  } else {
    const Series ts = read_series(path, in);
    std::vector<double> prod;
    for (std::size_t k = 0; k < ts.s.size(); ++k)
      if (ts.production[k]) prod.push_back(ts.s[k]);
    out["judged_from"] = "timeseries.csv";
    judge_drift(prod, out, reasons);
    judge_cut(ts, out, reasons);
  }
  out["equilibrated"] = reasons.empty();
  out["reasons"] = reasons;
  return out;
}

// The fits inflate their errors by sqrt(chi2/dof) above 1, an honest patch for a mild misfit
// (the long equilibrated runs' cubic fits sit at 1.2-2.0 over thousands of bins); beyond 3,
// error bars 1.7 times the statistical ones, the model itself misses the data. The 3 sd of
// chi2/dof's own scatter keep a fit of few bins from failing on noise.
double chi2_dof_limit(int dof) { return 3.0 + 3.0 * std::sqrt(2.0 / dof); }

// The variance a mode relaxing from zero must reach before production: at 95 % a mode's E
// reads ~5 % stiff, about the fits' errors.
constexpr double kRelaxedFraction = 0.95;

nlohmann::json judge_director_modes(const FrankSlowestMode &m, double sample_tau,
                                    double equilibration_tau) {
  nlohmann::json out{{"judged", false}, {"relaxed", true}, {"reason", ""}};
  if (!std::isfinite(m.lifetime_samples) || !(sample_tau > 0.0)) {
    out["note"] = "no lifetime: the bins need two or more replicas";
    return out;
  }
  const double life = m.lifetime_samples * sample_tau, production = m.replica_samples * sample_tau;
  out["slowest"] = {{"component", m.component == 1 ? "E13" : "E23"},
                    {"E", m.E},
                    {"k1sq", m.k1sq},
                    {"k3sq", m.k3sq},
                    {"lifetime_tau", life},
                    {"lifetime_at_least", m.outlives_replicas}};
  out["replica_production_tau"] = production;
  const std::string mode = fmt::format(
      "the slowest director mode of the fits ({} = {:.4f} at k1^2 {:.4f}, k3^2 {:.4f} D^-2)",
      m.component == 1 ? "E13" : "E23", m.E, m.k1sq, m.k3sq);
  std::string reason;
  if (m.outlives_replicas)
    reason = fmt::format(
        "{} lives at least as long as a replica's production ({:.3g} tau): the runs cannot average "
        "it and its relaxation cannot be judged; run several of its lifetimes longer",
        mode, production);
  if (std::isfinite(equilibration_tau)) {
    const double fraction = 1.0 - std::exp(-2.0 * equilibration_tau / life),
                 needed = -0.5 * life * std::log(1.0 - kRelaxedFraction);
    out["judged"] = true;
    out["equilibration_tau"] = equilibration_tau;
    out["relaxed_fraction"] = fraction;
    out["needed_equilibration_tau"] = needed;
    if (reason.empty() && fraction < kRelaxedFraction)
      reason = fmt::format(
          "{} lives ~{:.3g} tau; {:.3g} tau of equilibration from the start let its variance reach "
          "~{:.0f} % of equilibrium, so the K read high: equilibrate at least {:.3g} tau",
          mode, life, equilibration_tau, 100.0 * fraction, needed);
  } else {
    out["note"] = "the runs start from a file: the relaxation before it is not known";
  }
  out["relaxed"] = reason.empty();
  out["reason"] = reason;
  return out;
}

nlohmann::json judge_fit(const FrankModelFit &fit, bool equilibrated, const nlohmann::json &modes,
                         const nlohmann::json &halves) {
  const int dof = fit.dof_13 + fit.dof_23;
  const double chi2 = fit.chi2_dof();
  std::string reason;
  if (!(std::isfinite(fit.K1.value) && std::isfinite(fit.K2.value) && std::isfinite(fit.K3.value)))
    reason = "a constant is not determined";
  else if (!std::isfinite(chi2) || dof <= 0)
    reason = "no degrees of freedom to test the fit";
  else if (chi2 > chi2_dof_limit(dof))
    reason = fmt::format(
        "chi2/dof = {:.2f} over {} degrees of freedom, above {:.2f}: more misfit than the "
        "inflated errors absorb; the model or the range does not fit the data",
        chi2, dof, chi2_dof_limit(dof));
  else if (!equilibrated)
    reason = "its input is not equilibrated";
  else if (modes.is_object() && !modes.value("relaxed", true))
    reason = "the slowest director modes are not relaxed (see director_modes)";
  else if (halves.is_object() && halves.value("agree", nlohmann::json()).is_boolean() &&
           !halves["agree"].get<bool>())
    reason = fmt::format(
        "the production's halves disagree ({} by {:.1f} combined errors): the runs still drift",
        halves["max_pull_in"].get<std::string>(), halves["max_pull"].get<double>());
  return {{"trusted", reason.empty()}, {"reason", reason}};
}

}  // namespace hardrod
