// `hardrod analyze DIR [DIR ...]`: merges independent runs (different seeds) of one scene.
// S and P* from each run's summary.json; the Frank constants from each run's frank.json
// (the accumulated Fourier order tensor), fitted by kernels/frank_fit (planar, cubic and
// background estimators over ranges of k fixed in D^-2, errors from bin variances measured
// between runs). Writes analysis.json and, through scripts/plot_analysis.py, the paper's
// figures as PNG. Before any number it says whether its input can give the answer
// (runtime/analyze_verdict.hpp).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "kernels/frank_fit.hpp"

namespace hardrod {

struct AnalyzeOptions {
  std::vector<std::string> run_dirs;
  std::string output_dir;  // default: the first run directory
  FrankFitOptions frank;   // ranges, self-term subtraction (kT is taken as 1)
  bool plots = true;
  bool strict = false;       // `--strict`: an untrusted analysis is an error (exit 3)
  bool allow_mixed = false;  // `--allow-mixed`: merge runs of different dt, method or kmax
};

// Throws std::runtime_error with a message naming the file for unreadable input.
nlohmann::json analyze_runs(const AnalyzeOptions &options);

// Every run equilibrated and the recommended Frank fit (where there is one) trusted.
bool analysis_trusted(const nlohmann::json &analysis);

}  // namespace hardrod
