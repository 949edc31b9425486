// `hardrod analyze DIR [DIR ...]`: merges independent runs (different seeds) of one scene.
// S and P* from each run's summary.json; the Frank constants from each run's frank.json
// (the accumulated Fourier order tensor), fitted by kernels/frank_fit (planar, cubic and
// background estimators over ranges of k fixed in D^-2, errors from bin variances measured
// between runs). Writes analysis.json and, through scripts/plot_analysis.py, the paper's
// figures as PNG.
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
};

// Throws std::runtime_error with a message naming the file for unreadable input.
nlohmann::json analyze_runs(const AnalyzeOptions &options);

}  // namespace hardrod
