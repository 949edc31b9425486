// The Frank data as JSON and files: a run's accumulator (frank.json, and the string a
// checkpoint keeps of it) and the fitted constants (analysis.json's "frank"). The kernels
// (kernels/fourier_order_tensor.hpp, kernels/frank_fit.hpp) compute and never see JSON or
// files; this file only writes and reads, and does no physics.
//
// frank.json: {"format": "hardrod.frank_accumulator", "version": 1, "box": [Lx, Ly, Lz],
// "bodies", "kmax", "bin_width", "samples_per_block", "max_blocks", "bin_columns" (the 14
// names of a bin row), "blocks": [{"samples", "sum_S2", "bins": [[i1, i3, count, ...], ...]}]}.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "kernels/fourier_order_tensor.hpp"
#include "kernels/frank_fit.hpp"

namespace hardrod {

// The accumulator as it is, blocks and all: reading it back gives the same accumulator,
// which goes on accumulating as the original would.
nlohmann::json to_json(const FrankAccumulator &acc);
// Throws std::invalid_argument ("FrankAccumulator::from_json: ...") on malformed input.
FrankAccumulator frank_accumulator_from_json(const nlohmann::json &j);

// to_json(acc).dump() and a newline to `path`; throws std::runtime_error when it cannot.
void save_frank_accumulator(const FrankAccumulator &acc, const std::string &path);
// std::runtime_error for a file that cannot be read, std::invalid_argument for bad content.
FrankAccumulator load_frank_accumulator(const std::string &path);

// The fits, the variance model and the E tables; NaN written as null.
nlohmann::json to_json(const FrankResult &result);

}  // namespace hardrod
