// What `hardrod analyze` says of its input before any number: whether each run reached
// equilibrium, and whether each Frank fit is consistent with its errors (docs/frank.md,
// "When the analysis cannot be trusted"). A run is judged from its timeseries.csv: S over the
// production's first and last thirds (block-averaged, within 3 errors; kernels/block_average)
// and, where the run holds S(t) from its start, the MSER-5 cut, which must fall before
// production and below the search's cap. A fit is trusted when the input is equilibrated, its
// K are determined and chi^2/dof stays below chi2_dof_limit (a misfit its inflated errors can
// still absorb).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "kernels/frank_fit.hpp"

namespace hardrod {

// {run, equilibrated, reasons[], judged_from, production: {first_third, ..}, mser_cut_tau,
// cut_at_cap, production_starts_tau}. Falls back on summary.json's `equilibrated` where the
// run has no readable timeseries.csv, and says so. Throws std::runtime_error for a
// timeseries.csv that cannot be parsed, naming the file and the line.
nlohmann::json judge_run(const std::string &dir, const nlohmann::json &summary);

// {trusted, reason}: reason empty when trusted.
nlohmann::json judge_fit(const FrankModelFit &fit, bool equilibrated);

// The largest chi^2/dof a trusted fit with `dof` degrees of freedom may have: 3, plus 3 sd of
// chi^2/dof's scatter.
double chi2_dof_limit(int dof);

}  // namespace hardrod
