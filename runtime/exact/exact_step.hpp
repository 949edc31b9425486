// The exact method (run.method = "exact", docs/physics.md section 3b): every collision at its
// exact time inside the step. The bodies stay at the step's start until the collisions are
// known. Its phases of runtime/system.hpp:
//   1. the motion bounds grow by the step's free flight (grow_bounds), before anything moves
//   3. agree (the System): the list expires when those bounds reach the skin (then 4. rebuild);
//      on one rank body by body, each body's reach extended before the list is built again
//      (kernels/exact/list_extension.hpp)
//   2. detect: the listed pairs that could touch within the step (kernels/exact/
//      step_candidates.hpp)
//   5. collide: each cluster of them event by event (kernels/exact/exact_collisions.hpp); on
//      several ranks in rounds agreed between ranks (runtime/exact/exact_ranks.cpp)
//   6. flight: every body by dt (fly_step), the bodies whose velocity changed to their own end
//      states (land_flown)
// Every failure is agreed first, so that all ranks stop together.
#pragma once

#include <cstdint>
#include <vector>

#include "kernels/exact/exact_collisions.hpp"
#include "kernels/exact/list_extension.hpp"
#include "kernels/free_flight.hpp"
#include "runtime/exact/exact_protocol.hpp"
#include "runtime/step_method.hpp"
#include "runtime/system.hpp"

namespace hardrod {

struct ExactComponents;
struct ExactRound;

// The exact method's work, this rank's counts since it started: a cost diagnostic, not
// restored by a restart.
struct ExactRecord {
  long long steps = 0;
  ExactStats totals;              // summed over the steps (largest_cluster: the largest)
  long long rebuilt_in_step = 0;  // steps solved again on a new list: a body outran the skin
  // Clusters across ranks: rounds with an exchange of pieces, merged clusters solved here,
  // bodies set by another rank's results (--results-exchange).
  long long exchanges = 0, resolved = 0, from_results = 0;
};

class ExactStep final : public StepMethod {
 public:
  ExactStep(const ParallelOptions &parallel, int ranks);

  void step(System &system) override;
  void finish(System &system, bool next_follows) override;
  void summarize(Communicator &comm, nlohmann::json &summary) const override;
  void print_results(const nlohmann::json &summary) const override;

  const ExactRecord &record() const { return record_; }
  const ListExtension &extension() const { return extension_; }

 private:
  double bounds(System &sys);                  // 1: the step's flight in the bounds
  double rebuild(System &sys);                 // 4, then 1 again
  bool extend_list(System &sys, double lead);  // 4 without a build, where it pays (one rank)
  void check_flight(const System &sys, double largest, const char *what) const;
  DetectionStats collide(System &sys, ExactStats &stats);  // 2 and 5
  void tally(System &sys, const DetectionStats &detected, const ExactStats &stats);

  // Phase 5 on several ranks (exact_ranks.cpp).
  ExactStats collide_on_ranks(System &sys, double &reach);
  void solve_local_components(System &sys, ExactRound &round, const ExactComponents &cc,
                              const std::vector<char> &changed);
  void solve_spanning_components(System &sys, ExactRound &round, const ExactComponents &cc,
                                 const std::vector<char> &changed);
  std::vector<std::int64_t> exchange_pieces(System &sys, ExactRound &round,
                                            const ExactComponents &cc,
                                            const std::vector<char> &changed);
  void forward_pieces(System &sys, ExactRound &round, std::vector<std::int64_t> &fresh);
  void post_piece(const System &sys, const std::vector<ExactPieces::Body> &bodies,
                  const std::vector<ExactPieces::Edge> &edges);
  void forward_piece(System &sys, const std::vector<ExactPieces::Body> &bodies,
                     const std::vector<ExactPieces::Edge> &edges);
  void open_messages(const System &sys, const std::vector<ExactResult> &results);
  void swap_pieces(System &sys, ExactPieces &pieces, std::size_t first, std::size_t first_edge,
                   std::vector<std::int64_t> &fresh, std::vector<ExactResult> &results);
  // --results-exchange for the exact method: on two ranks, where one exchange of pieces gives
  // every rank its clusters whole (on more, pieces are forwarded instead and the switch is
  // ignored: a solver could not reach every rank that needs its results).
  bool results_path(int ranks) const { return results_exchange_ && ranks == 2; }
  void exchange_exact_results(System &sys, ExactRound &round,
                              const std::vector<ExactResult> &results);
  void settle_exact(ExactRound &round, std::uint32_t body, const ExactResult &result) const;
  void replace_exact(const System &sys, ExactRound &round, const ExactResult &result) const;
  ExactStats exact_counts(const System &sys, const ExactRound &round,
                          const std::vector<FlownBody> &flown) const;

  ExactSettings settings_;
  bool results_exchange_ = false;  // ParallelOptions::results_exchange
  // One rank extends its lists body by body (ParallelOptions::extend_lists).
  bool extend_lists_ = true;
  ListExtension extension_;
  GrownBounds grown_;  // bounds: what the step's flight made of the bounds
  std::vector<Candidate> candidates_;
  ExactScratch scratch_;
  std::vector<FlownBody> flown_;
  std::vector<std::uint32_t> changed_;  // scratch: the flown bodies
  ExactProblem problem_;                // the spanning clusters solved here (exact_ranks.cpp)
  std::vector<std::vector<char>> out_;  // the messages to the partners
  ExactRecord record_;
};

}  // namespace hardrod
