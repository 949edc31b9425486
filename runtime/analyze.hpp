// `hardrod analyze DIR [DIR ...]`: merges independent runs (different seeds) of one scene.
// S and P* from each run's summary.json; the Frank constants from each run's frank.json
// (the accumulated Fourier order tensor), fitted by kernels/frank_fit (plane for
// k^2 < 0.1, bivariate cubic without constant term), errors from the spread over runs or
// a jackknife over blocks of one run. Writes analysis.json and, through
// scripts/plot_analysis.py, the paper's figures as PNG.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace hardrod {

struct AnalyzeOptions {
  std::vector<std::string> run_dirs;
  std::string output_dir;           // default: the first run directory
  bool subtract_self_term = false;  // see FrankFitOptions
  bool plots = true;
};

// Throws std::runtime_error with a message naming the file for unreadable input.
nlohmann::json analyze_runs(const AnalyzeOptions &options);

}  // namespace hardrod
