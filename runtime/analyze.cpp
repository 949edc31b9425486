#include "runtime/analyze.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include "kernels/frank_fit.hpp"

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

nlohmann::json estimate(const FrankEstimate &e) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  return {{"mean", num(e.value)}, {"error", num(e.error)}};
}

std::string pm(const nlohmann::json &e) {
  if (!e.at("mean").is_number()) return "n/a";
  if (!e.at("error").is_number()) return fmt::format("{:.4f}", e.at("mean").get<double>());
  return fmt::format("{:.4f} +/- {:.4f}", e.at("mean").get<double>(), e.at("error").get<double>());
}

}  // namespace

nlohmann::json analyze_runs(const AnalyzeOptions &options) {
  if (options.run_dirs.empty()) throw std::runtime_error("analyze: no run directory given");
  std::vector<nlohmann::json> summaries;
  std::vector<FrankAccumulator> frank;
  for (const auto &dir : options.run_dirs) {
    summaries.push_back(read_json(fs::path(dir) / "summary.json"));
    const fs::path f = fs::path(dir) / "frank.json";
    if (fs::exists(f)) {
      try {
        frank.push_back(FrankAccumulator::load(f.string()));
      } catch (const std::exception &e) {
        throw std::runtime_error(fmt::format("{}: {}", f.string(), e.what()));
      }
    }
  }
  nlohmann::json out;
  out["runs"] = options.run_dirs.size();
  out["run_dirs"] = options.run_dirs;
  out["order_parameter"] = merge_estimates(summaries, "order_parameter");
  out["pressure_star"] = merge_estimates(summaries, "pressure_star");
  out["samples"] = out["order_parameter"]["samples"];
  if (!frank.empty() && frank.size() != options.run_dirs.size())
    throw std::runtime_error(
        fmt::format("analyze: {} of {} run directories have frank.json; merge only runs made with "
                    "[observables] frank = true",
                    frank.size(), options.run_dirs.size()));
  if (!frank.empty()) {
    FrankFitOptions fo;
    fo.subtract_self_term = options.subtract_self_term;
    const FrankResult r = fit_frank(frank, fo);
    for (const char *k : {"K1", "K2", "K3"}) {
      const auto pick = [&](const FrankModelFit &f) {
        return std::string(k) == "K1" ? f.K1 : std::string(k) == "K2" ? f.K2 : f.K3;
      };
      out[k] = {{"planar", estimate(pick(r.planar))}, {"cubic", estimate(pick(r.cubic))}};
    }
    out["frank"] = to_json(r);
    out["fourier_samples"] = r.samples;
  }
  const fs::path outdir = options.output_dir.empty() ? fs::path(options.run_dirs.front())
                                                     : fs::path(options.output_dir);
  fs::create_directories(outdir);
  {
    std::ofstream f(outdir / "analysis.json");
    f << out.dump(2) << "\n";
  }

  fmt::print("analysis of {} run(s):\n", options.run_dirs.size());
  fmt::print("  order parameter S   {}\n", pm(out["order_parameter"]));
  fmt::print("  pressure P*         {}\n", pm(out["pressure_star"]));
  if (out.contains("K1")) {
    fmt::print("  Frank constants (K* = beta D K), {} Fourier samples, errors: {}\n",
               out["fourier_samples"].get<long long>(),
               out["frank"]["error_method"].get<std::string>());
    fmt::print("  {:<6}{:>24}{:>24}\n", "", "planar (k^2 < 0.1)", "cubic");
    for (const char *k : {"K1", "K2", "K3"})
      fmt::print("  {:<6}{:>24}{:>24}\n", k, pm(out[k]["planar"]), pm(out[k]["cubic"]));
  }
  fmt::print("  written             {}\n", (outdir / "analysis.json").string());

  if (options.plots) {
    // The figures come from a real plotting library (matplotlib), in a script users can
    // also run by hand.
    std::string cmd = "python3 \"" HARDROD_SOURCE_DIR "/scripts/plot_analysis.py\" --out \"" +
                      outdir.string() + "\"";
    for (const auto &d : options.run_dirs) cmd += " \"" + d + "\"";
    std::fflush(stdout);
    if (std::system(cmd.c_str()) != 0) fmt::print("  plots: not made (run by hand: {})\n", cmd);
  }
  return out;
}

}  // namespace hardrod
