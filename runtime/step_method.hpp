// How a step advances the bodies: the interface of the step methods, chosen once where the
// System is built (make_step_method, from run.method). A method runs phases 1, 2, 5 and 6 of
// runtime/system.hpp and calls the System for phases 3 and 4; the System runs 7 and 8 after
// every step, whatever the method. Each method owns its own state, its cross-rank protocol and
// its part of the report, in its own folder: runtime/midpoint/ (the paper's method: contacts
// resolved at the step's midpoint) and runtime/exact/ (every collision at its time). A further
// method adds a folder and one line in make_step_method.
#pragma once

#include <memory>
#include <nlohmann/json_fwd.hpp>

namespace hardrod {

class Communicator;
class System;
struct ParallelOptions;
struct Scene;

class StepMethod {
 public:
  virtual ~StepMethod() = default;
  // Phases 1-5 of one step, phases 3 and 4 through the System. The motion constants of the
  // advanced bodies are current (System::advance refreshes them before each burst of steps).
  virtual void step(System &system) = 0;
  // Phase 6, after the System counted the step. `next_follows`: the next step comes at once
  // and nothing acts between the two (no constraint, thermostat, stop or end of the burst), so
  // the method may run the next step's phase 1 in the same pass.
  virtual void finish(System &system, bool next_follows) = 0;
  // Collective: the method's part of summary.json (docs/outputs.md), added to `summary`.
  virtual void summarize(Communicator &comm, nlohmann::json &summary) const = 0;
  // The method's lines of the run report, from summary.json: among the results, and with the
  // parallel bookkeeping of a run on several ranks.
  virtual void print_results(const nlohmann::json &summary) const;
  virtual void print_parallel(const nlohmann::json &summary) const;
};

// The scene's method (run.method), for a System of `ranks` ranks.
std::unique_ptr<StepMethod> make_step_method(const Scene &scene, const ParallelOptions &parallel,
                                             int ranks);

}  // namespace hardrod
