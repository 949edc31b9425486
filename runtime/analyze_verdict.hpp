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

// Whether the slowest director mode of the fits (slowest_mode) had time to relax before
// production and is averaged by it. `sample_tau`: tau between Fourier samples; equilibration:
// tau before production, from an aligned or isotropic start (NaN: the runs start from a file,
// whose history is not known: the relaxation is not judged). {judged, relaxed, reason,
// slowest: {component, E, k1sq, k3sq, lifetime_tau, lifetime_at_least}, equilibration_tau,
// relaxed_fraction, needed_equilibration_tau}. Relaxed: 1 - exp(-2 t / lifetime) >= 0.95
// and the lifetime shorter than a replica's production.
nlohmann::json judge_director_modes(const FrankSlowestMode &slowest, double sample_tau,
                                    double equilibration_tau);

// {trusted, reason}: reason empty when trusted. `modes`: judge_director_modes's verdict;
// `halves`: the fit's production halves ({agree, max_pull, max_pull_in}); either null where
// there is none.
nlohmann::json judge_fit(const FrankModelFit &fit, bool equilibrated,
                         const nlohmann::json &modes = nullptr,
                         const nlohmann::json &halves = nullptr);

// The largest chi^2/dof a trusted fit with `dof` degrees of freedom may have: 3, plus 3 sd of
// chi^2/dof's scatter.
double chi2_dof_limit(int dof);

}  // namespace hardrod
