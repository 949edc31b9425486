// The choice of a step method, made once where the System is built.
#include "runtime/step_method.hpp"

#include "runtime/exact/exact_step.hpp"
#include "runtime/midpoint/midpoint_step.hpp"

namespace hardrod {

void StepMethod::print_results(const nlohmann::json &) const {}
void StepMethod::print_parallel(const nlohmann::json &) const {}

std::unique_ptr<StepMethod> make_step_method(const Scene &scene, const ParallelOptions &parallel,
                                             int ranks) {
  if (scene.method == kExact) return std::make_unique<ExactStep>(parallel, ranks);
  return std::make_unique<MidpointStep>(scene, parallel);
}

}  // namespace hardrod
