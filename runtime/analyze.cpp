#include "runtime/analyze.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <tuple>

#include "kernels/frank_fit.hpp"
#include "runtime/analyze_verdict.hpp"
#include "runtime/frank_io.hpp"
#include "runtime/run_files.hpp"

namespace hardrod {

namespace {

namespace fs = std::filesystem;

nlohmann::json read_json(const fs::path &path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot open", path.string()));
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception &e) {
    throw std::runtime_error(fmt::format("{}: not valid JSON ({})", path.string(), e.what()));
  }
}

// Mean of the runs' means; error: the spread over runs / sqrt(runs) with two or more runs
// (never below the runs' own combined error), the run's block-averaged error with one.
nlohmann::json merge_estimates(const std::vector<nlohmann::json> &summaries, const char *key) {
  double sum = 0.0, own = 0.0;
  long long samples = 0;
  std::vector<double> means;
  for (const auto &s : summaries) {
    const auto &e = s.at(key);
    const double m = e.at("mean").get<double>();
    means.push_back(m);
    sum += m;
    const double err = e.at("error").is_number() ? e.at("error").get<double>() : NAN;
    own += err * err;
    samples += e.value("samples", 0LL);
  }
  const double n = static_cast<double>(means.size());
  const double mean = sum / n;
  double error = std::sqrt(own) / n;
  if (means.size() >= 2) {
    double ss = 0.0;
    for (double m : means) ss += (m - mean) * (m - mean);
    error = std::max(error, std::sqrt(ss / (n - 1.0) / n));
  }
  return {{"mean", mean},
          {"error", std::isfinite(error) ? nlohmann::json(error) : nlohmann::json(nullptr)},
          {"samples", samples}};
}

// One estimate of one fit: mean, error (fit), spread (replicas), chi2_dof, bins. A value the
// fit could not determine (too few bins, not positive) is null, never NaN or negative.
nlohmann::json estimate(const FrankEstimate &e, double chi2_dof, int bins) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  return {{"mean", num(e.value)},    {"error", num(e.error)},     {"fit_error", num(e.fit_error)},
          {"spread", num(e.spread)}, {"chi2_dof", num(chi2_dof)}, {"bins", bins}};
}

// analysis.json's K1, K2, K3, K3_from_E13, K3_from_E23: {planar, cubic, background} each.
void add_frank_constants(nlohmann::json &out, const FrankResult &r) {
  const std::pair<const char *, const FrankModelFit *> models[] = {
      {"planar", &r.planar}, {"cubic", &r.cubic}, {"background", &r.background}};
  for (const auto &[name, f] : models) {
    out["K1"][name] = estimate(f->K1, f->chi2_13, f->bins_13);
    out["K2"][name] = estimate(f->K2, f->chi2_23, f->bins_23);
    out["K3"][name] = estimate(f->K3, f->chi2_dof(), f->bins_13 + f->bins_23);
    out["K3_from_E13"][name] = estimate(f->K3_13, f->chi2_13, f->bins_13);
    out["K3_from_E23"][name] = estimate(f->K3_23, f->chi2_23, f->bins_23);
  }
}

// The runs' start: from a file, the relaxation before it is unknown; NaN then, and where
// scene.toml cannot be read.
double equilibration_from_start(const std::string &dir, const nlohmann::json &summary) {
  try {
    const toml::table scene = toml::parse_file((fs::path(dir) / "scene.toml").string());
    if (scene["init"]["configuration"].value_or(std::string("lattice")) == "file") return NAN;
  } catch (const std::exception &) {
    return NAN;
  }
  return summary.value("equilibration_steps", 0.0) * summary.value("dt", NAN);
}

// analysis.json's director_modes: the slowest mode's relaxation, judged on the shortest
// equilibration and the first run's Fourier sampling (production time / samples).
nlohmann::json director_modes(const FrankResult &r, const std::vector<std::string> &dirs,
                              const std::vector<nlohmann::json> &summaries) {
  double equilibration = INFINITY;
  for (std::size_t k = 0; k < dirs.size(); ++k) {
    const double t = equilibration_from_start(dirs[k], summaries[k]);
    equilibration = std::isnan(t) || std::isnan(equilibration) ? NAN : std::min(equilibration, t);
  }
  const double samples = summaries.front().value("frank_samples", 0.0);
  const double sample_tau =
      samples > 0.0 ? summaries.front().value("production_time", NAN) / samples : NAN;
  return judge_director_modes(slowest_mode(r), sample_tau, equilibration);
}

// The production's halves fitted apart (each run's first halves together, then its second
// halves): per fit, the K of each and the largest pull |a - b| / sqrt(ea^2 + eb^2); they agree
// below 3 (null where a half cannot determine the K).
nlohmann::json production_halves(const std::vector<FrankAccumulator> &frank,
                                 const FrankFitOptions &options) {
  std::vector<FrankAccumulator> first, second;
  for (const FrankAccumulator &f : frank) {
    const auto h = f.halves();
    first.push_back(h[0]), second.push_back(h[1]);
  }
  if (first.front().samples() == 0 || second.front().samples() == 0) return nullptr;
  const FrankResult a = fit_frank(first, options), b = fit_frank(second, options);
  nlohmann::json out;
  const std::pair<const char *, const FrankModelFit FrankResult::*> models[] = {
      {"planar", &FrankResult::planar},
      {"cubic", &FrankResult::cubic},
      {"background", &FrankResult::background}};
  for (const auto &[name, member] : models) {
    const FrankModelFit &fa = a.*member, &fb = b.*member;
    double worst = 0.0;
    std::string which;
    nlohmann::json fit;
    for (const auto &[k, ea, eb] : {std::tuple{"K1", fa.K1, fb.K1}, std::tuple{"K2", fa.K2, fb.K2},
                                    std::tuple{"K3", fa.K3, fb.K3}}) {
      fit["first"][k] = estimate(ea, NAN, 0);
      fit["second"][k] = estimate(eb, NAN, 0);
      const double pull = std::fabs(ea.value - eb.value) / std::hypot(ea.error, eb.error);
      if (!std::isfinite(pull)) worst = NAN;
      if (std::isfinite(worst) && pull > worst) worst = pull, which = k;
    }
    fit["max_pull"] = std::isfinite(worst) ? nlohmann::json(worst) : nlohmann::json();
    fit["max_pull_in"] = which;
    fit["agree"] = std::isfinite(worst) ? nlohmann::json(worst < 3.0) : nlohmann::json();
    out[name] = fit;
  }
  return out;
}

// Per fit {trusted, reason}; the same verdict beside each of its estimates.
void add_fit_verdicts(nlohmann::json &out, const FrankResult &r, bool equilibrated) {
  const std::pair<const char *, const FrankModelFit *> models[] = {
      {"planar", &r.planar}, {"cubic", &r.cubic}, {"background", &r.background}};
  for (const auto &[name, f] : models) {
    const nlohmann::json halves =
        out["production_halves"].is_object() ? out["production_halves"][name] : nlohmann::json();
    const nlohmann::json v = judge_fit(*f, equilibrated, out["director_modes"], halves);
    out["frank_fits"][name] = v;
    for (const char *k : {"K1", "K2", "K3", "K3_from_E13", "K3_from_E23"})
      out[k][name]["trusted"] = v["trusted"];
  }
}

// The warnings, in words, before any number.
void print_warnings(const nlohmann::json &out) {
  for (const auto &run : out["equilibration"]["runs"])
    for (const auto &why : run["reasons"])
      fmt::print("WARNING: {} is not equilibrated: {}\n", run["run"].get<std::string>(),
                 why.get<std::string>());
  if (!out.contains("frank_fits")) return;
  if (!out["director_modes"]["relaxed"].get<bool>())
    fmt::print("WARNING: {}\n", out["director_modes"]["reason"].get<std::string>());
  for (const auto &[name, v] : out["frank_fits"].items())
    if (!v["trusted"].get<bool>())
      fmt::print("WARNING: the {} fit{} is not trusted: {}\n", name,
                 name == out["frank_recommended_fit"] ? " (the recommended one)" : "",
                 v["reason"].get<std::string>());
}

std::string pm(const nlohmann::json &e) {
  if (!e.at("mean").is_number()) return "not determined";
  if (!e.at("error").is_number()) return fmt::format("{:.4f}", e.at("mean").get<double>());
  return fmt::format("{:.4f} +/- {:.4f}", e.at("mean").get<double>(), e.at("error").get<double>());
}

std::string chi2_text(const nlohmann::json &e) {
  return e.at("chi2_dof").is_number() ? fmt::format("{:.2f}", e.at("chi2_dof").get<double>()) : "-";
}

void print_frank(const nlohmann::json &out, const FrankFitOptions &o) {
  fmt::print("  Frank constants (K* = beta D K), {} Fourier samples; {}\n",
             out["fourier_samples"].get<long long>(),
             out["frank"]["error_method"].get<std::string>());
  fmt::print("  {:<9}{:>22}{:>22}{:>22}\n", "", fmt::format("planar (k^2<{:g})", o.planar_max_k2),
             fmt::format("cubic ({:g}, {:g}) *", o.cubic_max_k1sq, o.cubic_max_k3sq), "background");
  for (const char *k : {"K1", "K2", "K3", "K3_from_E13", "K3_from_E23"}) {
    const std::string label =
        std::string(k).size() > 2 ? "K3(E" + std::string(k).substr(9) + ")" : k;
    fmt::print("  {:<9}{:>22}{:>22}{:>22}\n", label, pm(out[k]["planar"]), pm(out[k]["cubic"]),
               pm(out[k]["background"]));
  }
  fmt::print("  {:<9}{:>22}{:>22}{:>22}\n", "chi2/dof", chi2_text(out["K3"]["planar"]),
             chi2_text(out["K3"]["cubic"]), chi2_text(out["K3"]["background"]));
  fmt::print(
      "  * the recommended fit (docs/frank.md). Errors: the fit's, inflated by sqrt(chi2/dof) "
      "where\n"
      "    above 1, or the spread of the runs' own fits where larger (three runs or more)\n");
}

// A failed run, or one without production samples, has no results to merge.
void check_has_results(const std::string &dir, const nlohmann::json &summary) {
  const std::string status = summary.value("status", std::string("completed"));
  if (status == "failed")
    throw std::runtime_error(fmt::format(
        "{}: the run failed ({}); it has no results to analyze", dir,
        summary.contains("error") ? summary["error"].dump() : std::string("no reason recorded")));
  const auto &s = summary.at("order_parameter");
  if (!s.at("mean").is_number() || s.value("samples", 0LL) <= 0)
    throw std::runtime_error(
        fmt::format("{}: no production samples (status {}, steps_done {}); nothing to analyze", dir,
                    status, summary.value("steps_done", 0LL)));
}

// Runs merge only when they simulate one system (seeds and lengths may differ).
void check_same_system(const std::vector<std::string> &dirs,
                       const std::vector<nlohmann::json> &summaries) {
  const auto system = [](const nlohmann::json &s) {
    return fmt::format("n = {}, L/D = {}, box {}", s.value("n", nlohmann::json()).dump(),
                       s.value("aspect_ratio", nlohmann::json()).dump(),
                       s.value("box", nlohmann::json()).dump());
  };
  for (std::size_t k = 1; k < summaries.size(); ++k)
    if (system(summaries[k]) != system(summaries[0]))
      throw std::runtime_error(fmt::format(
          "analyze: {} ({}) and {} ({}) are runs of different systems; merge only runs of one "
          "system",
          dirs[0], system(summaries[0]), dirs[k], system(summaries[k])));
}

// Runs merge as independent samples of one protocol: the same dt and method (P* carries a dt
// bias under the midpoint method), and Fourier modes to the same kmax, unless the user allows
// mixing; never two copies of one trajectory (same seed or same final state).
void check_same_protocol(const std::vector<std::string> &dirs,
                         const std::vector<nlohmann::json> &summaries, bool allow_mixed) {
  const auto text = [](const nlohmann::json &s, const char *key) {
    return s.contains(key) ? s[key].dump() : std::string("absent");
  };
  for (std::size_t k = 1; k < summaries.size(); ++k) {
    for (std::size_t j = 0; j < k; ++j)
      for (const char *key : {"seed", "state_checksum"})
        if (summaries[k].contains(key) && text(summaries[k], key) == text(summaries[j], key))
          throw std::runtime_error(fmt::format(
              "analyze: {} and {} have the same {} ({}): copies of one run are not independent "
              "samples; give each run once (runs of one scene differ in init.seed)",
              dirs[j], dirs[k], key, text(summaries[k], key)));
    if (allow_mixed) continue;
    std::vector<std::string> differ;
    for (const char *key : {"dt", "method"})
      if (text(summaries[k], key) != text(summaries[0], key))
        differ.push_back(fmt::format("run.{} {} against {}", key, text(summaries[0], key),
                                     text(summaries[k], key)));
    if (!differ.empty())
      throw std::runtime_error(fmt::format(
          "analyze: {} and {} differ in {}; merge runs of one protocol, or pass --allow-mixed",
          dirs[0], dirs[k], fmt::join(differ, ", ")));
  }
}

// Each run directory at most once.
void check_distinct(const std::vector<std::string> &dirs) {
  for (size_t a = 0; a < dirs.size(); ++a)
    for (size_t b = 0; b < a; ++b) {
      std::error_code ea, eb;
      if (fs::equivalent(dirs[a], dirs[b], ea) && !ea && !eb)
        throw std::runtime_error(
            fmt::format("analyze: {} and {} are the same run directory; each run may be given once",
                        dirs[b], dirs[a]));
    }
}

// Every run's summary.json (with results), and its frank.json where it has one.
void load_runs(const std::vector<std::string> &dirs, std::vector<nlohmann::json> &summaries,
               std::vector<FrankAccumulator> &frank) {
  for (const auto &dir : dirs) {
    summaries.push_back(read_json(fs::path(dir) / "summary.json"));
    check_has_results(dir, summaries.back());
    const fs::path f = fs::path(dir) / "frank.json";
    if (!fs::exists(f)) continue;
    try {
      frank.push_back(load_frank_accumulator(f.string()));
    } catch (const std::exception &e) {
      throw std::runtime_error(fmt::format("{}: {}", f.string(), e.what()));
    }
  }
}

// analysis.json in outdir, and the results on the terminal.
void report(const nlohmann::json &out, const fs::path &outdir, const AnalyzeOptions &options) {
  fs::create_directories(outdir);
  write_atomically(outdir / "analysis.json", out.dump(2) + "\n");  // checked: never a short file
  print_warnings(out);
  fmt::print("analysis of {} run(s){}:\n", options.run_dirs.size(),
             out["equilibrated"].get<bool>() ? "" : " (NOT EQUILIBRATED: see the warnings)");
  fmt::print("  order parameter S   {}\n", pm(out["order_parameter"]));
  fmt::print("  pressure P*         {}\n", pm(out["pressure_star"]));
  if (out.contains("K1")) print_frank(out, options.frank);
  fmt::print("  written             {}\n", (outdir / "analysis.json").string());
}

// The figures come from a real plotting library (matplotlib), in a script users can also run
// by hand; if it fails, the command is printed.
void plot(const fs::path &outdir, const AnalyzeOptions &options) {
  std::string cmd = "python3 \"" HARDROD_SOURCE_DIR "/scripts/plot_analysis.py\" --out \"" +
                    outdir.string() + "\"";
  for (const auto &d : options.run_dirs) cmd += " \"" + d + "\"";
  std::fflush(stdout);
  if (std::system(cmd.c_str()) != 0) fmt::print("  plots: not made (run by hand: {})\n", cmd);
}

}  // namespace

bool analysis_trusted(const nlohmann::json &analysis) {
  if (!analysis.value("equilibrated", false)) return false;
  if (!analysis.contains("frank_fits")) return true;
  const std::string fit = analysis["frank_recommended_fit"].get<std::string>();
  return analysis["frank_fits"][fit]["trusted"].get<bool>();
}

nlohmann::json analyze_runs(const AnalyzeOptions &options) {
  if (options.run_dirs.empty()) throw std::runtime_error("analyze: no run directory given");
  check_distinct(options.run_dirs);
  std::vector<nlohmann::json> summaries;
  std::vector<FrankAccumulator> frank;
  load_runs(options.run_dirs, summaries, frank);
  check_same_system(options.run_dirs, summaries);
  check_same_protocol(options.run_dirs, summaries, options.allow_mixed);
  nlohmann::json out;
  out["runs"] = options.run_dirs.size();
  out["run_dirs"] = options.run_dirs;
  out["order_parameter"] = merge_estimates(summaries, "order_parameter");
  out["pressure_star"] = merge_estimates(summaries, "pressure_star");
  out["samples"] = out["order_parameter"]["samples"];
  nlohmann::json runs = nlohmann::json::array();
  bool equilibrated = true;
  for (std::size_t k = 0; k < summaries.size(); ++k) {
    runs.push_back(judge_run(options.run_dirs[k], summaries[k]));
    equilibrated = equilibrated && runs.back()["equilibrated"].get<bool>();
  }
  out["equilibrated"] = equilibrated;
  out["equilibration"] = {{"runs", runs}};
  if (!frank.empty() && frank.size() != options.run_dirs.size())
    throw std::runtime_error(
        fmt::format("analyze: {} of {} run directories have frank.json; merge only runs made with "
                    "[observables] frank = true",
                    frank.size(), options.run_dirs.size()));
  if (!frank.empty() && !options.allow_mixed)
    for (std::size_t k = 1; k < frank.size(); ++k)
      if (frank[k].kmax() != frank[0].kmax())
        throw std::runtime_error(fmt::format(
            "analyze: {} and {} differ in observables.fourier_kmax ({} against {}); merge runs "
            "of one protocol, or pass --allow-mixed",
            options.run_dirs[0], options.run_dirs[k], frank[0].kmax(), frank[k].kmax()));
  if (!frank.empty()) {
    const FrankResult r = fit_frank(frank, options.frank);
    add_frank_constants(out, r);
    out["frank_recommended_fit"] = "cubic";  // why: docs/frank.md
    out["director_modes"] = director_modes(r, options.run_dirs, summaries);
    out["production_halves"] = production_halves(frank, options.frank);
    add_fit_verdicts(out, r, equilibrated);
    out["frank"] = to_json(r);
    out["fourier_samples"] = r.samples;
  }
  const fs::path outdir = options.output_dir.empty() ? fs::path(options.run_dirs.front())
                                                     : fs::path(options.output_dir);
  report(out, outdir, options);
  if (options.plots) plot(outdir, options);
  return out;
}

}  // namespace hardrod
