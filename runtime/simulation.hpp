// The state of a run and one time step (docs/physics.md sections 3 and 7). One time step, the
// phases numbered once here for every file (advance(), runtime/simulation.cpp):
//   1. first half: free flight of the owned bodies and shadows to the midpoint (to_midpoint,
//      kernels/free_flight.hpp), with phase 2 in the same pass when the pair list keeps watches
//   2. detect: contacts at the midpoint (detect, kernels/contact_detection.hpp)
//   3. agree: the step's one max-reduction: a pair list expired, a contact across a rank
//      boundary, problems, a stop (agree)
//   4. rebuild when due: new cuts, migration, shadows, the pair list (rebuild,
//      runtime/decomposition.cpp), then phase 2 again
//   5. resolve: elastic impulses (resolve), (a) of the clusters this rank holds in full
//      (kernels/contact_resolution.hpp), (b) of those across ranks, with one exchange of
//      contact records and, on more than two ranks, one of results (resolve_across_ranks,
//      runtime/spanning_clusters.cpp and runtime/cluster_protocol.hpp)
//   6. second half: free flight to the end of the step, in one pass with the next step's
//      phase 1 where nothing acts between them (second_half, to_midpoint(2))
//   7. when due: the rotor constraints and the thermostat (restore_constraints,
//      apply_thermostat)
//   8. when due: the load balance check (check_balance, runtime/balance_check.cpp)
// Each phase is a named, timed call; every communication step is a named, counted call into
// runtime/comm. One rank runs the same code with no partners. Physics that breaks (overlap
// beyond run.max_overlap, NaN) throws PhysicsError naming the step and dt, on every rank.
// Observables are in runtime/observables.cpp, the checksum and checks in
// runtime/diagnostics.cpp.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "kernels/contact.hpp"
#include "kernels/contact_detection.hpp"
#include "kernels/contact_resolution.hpp"
#include "kernels/exact_collisions.hpp"
#include "kernels/exact_sum.hpp"
#include "kernels/fourier_order_tensor.hpp"
#include "kernels/free_flight.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/order_tensor.hpp"
#include "kernels/particles.hpp"
#include "perf/region_timer.hpp"
#include "runtime/balance.hpp"
#include "runtime/cluster_protocol.hpp"
#include "runtime/comm.hpp"
#include "runtime/domain.hpp"
#include "runtime/exact_protocol.hpp"
#include "runtime/scene.hpp"

namespace hardrod {

struct ExactComponents;
struct ExactRound;

class PhysicsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ParallelOptions {
  std::array<int, 3> grid{0, 0, 0};  // ranks per axis; zeros: MPI_Dims_create decides
  BalanceOptions balance;            // moving the cuts (runtime/balance.hpp)
  // For tests: a rank resolves only the spanning clusters whose first contact's lower-id
  // body it owns, and takes the others from the results exchange, which then runs on any
  // rank count (it is otherwise needed on more than two ranks only, and rarely).
  bool results_exchange = false;
  // The exact method's list on one rank is extended body by body before it is built again
  // (kernels/list_extension.hpp): the same trajectory. False builds it at every expiry (tests,
  // comparisons).
  bool extend_lists = true;
};

// What the load balancer did (runtime/balance.hpp); the same on every rank.
struct BalanceRecord {
  long long checks = 0;           // load comparisons between ranks
  long long shifts = 0;           // new cuts taken into use
  long long forced_rebuilds = 0;  // rebuilds done for new cuts (the others came at a rebuild)
  double first_imbalance = 0.0;   // busiest rank's load / mean - 1, at the first check
  double last_imbalance = 0.0;    // and at the last
  double max_imbalance = 0.0;
  double largest_shift = 0.0;  // of one cut at one rebuild (D); moved in stages past half
                               // the partner reach
};

// Clusters with bodies on several ranks (Simulation::resolve_across_ranks), this rank's
// counts since it started: a diagnostic of the protocol, not restored by a restart.
struct SpanningRecord {
  long long exchanges = 0;      // steps with an exchange of contact records
  long long resolved = 0;       // clusters this rank resolved from merged records
  long long multi_contact = 0;  // of those, with more than one contact
  long long put_together = 0;   // of those, with a contact this rank did not detect
  long long from_results = 0;   // bodies set by another rank's results (more than two ranks)
};

// The exact method's work (run.method = "exact", kernels/exact_collisions.hpp), this rank's
// counts since it started: a cost diagnostic, not restored by a restart.
struct ExactRecord {
  long long steps = 0;
  ExactStats totals;              // summed over the steps (largest_cluster: the largest)
  long long rebuilt_in_step = 0;  // steps solved again on a new list: a body outran the skin
};

// Running totals since the last call to Simulation::take_interval(), for this rank's
// share (contacts are counted by the rank that owns their lower-id body).
struct IntervalTotals {
  long long steps = 0;
  long long collisions = 0;
  long long narrow_phase_tests = 0;
  long long contacts = 0;
  long long multi_contact_bodies = 0;
  long long clusters = 0;
  long long solver_iterations_max = 0;
  long long solver_unconverged = 0;
  double max_depth = 0.0;
  ExactSum solver_energy_change;  // kinetic energy the multi-contact solver changed
  ExactSum virial;                // sum of J n . (x_i - x_j)
};

// The thermostat's record of the relative kinetic-energy error it removed (drift).
struct ThermostatRecord {
  double correction_sum = 0.0;  // sum of (KE / target - 1) over applications, in order
  long long applications = 0;
};

// One sample of the whole system (collective: every rank gets the same numbers).
struct Observation {
  long long step = 0;
  double order_parameter = 0.0;
  Vec3 director;
  double kinetic_energy = 0.0;
  double temperature = 0.0;
  IntervalTotals totals;  // summed over ranks
};

// The scene's initial bodies, all n in id order, the same on every rank: on the aligned
// lattice, a random isotropic state compressed to the density (init.configuration =
// "isotropic"), or positions and axes from an H5MD frame ("file"; n and box must match).
// Velocities fresh at the scene's temperature. Throws SceneError.
// `stoppable`: a stop signal ends a long set-up (the isotropic compression) with
// CompressionStopped; only on one rank, where no other rank can be left waiting.
Particles initial_bodies(const Scene &scene, bool stoppable = false);

class Simulation {
 public:
  // Starts from the scene's lattice with fresh velocities.
  explicit Simulation(Scene scene, ParallelOptions parallel = {});
  // Starts from given bodies (all n of them, on every rank; each keeps its own) at step
  // `first_step` (a restart: the step number keys the thermostat and constraint schedule).
  Simulation(Scene scene, Particles bodies, ParallelOptions parallel = {},
             long long first_step = 0);

  void step();
  // `count` steps, bit for bit the same as `count` calls of step() but faster (two half
  // steps fused into one pass between steps); returns early after a step that agreed to stop.
  void advance(long long count);

  const Scene &scene() const { return scene_; }
  // Bodies held by this rank: [0, owned_count()) owned, the rest shadows.
  const Particles &particles() const { return particles_; }
  Particles &particles() { return particles_; }
  std::size_t owned_count() const { return owned_; }
  long long current_step() const { return step_; }
  double time() const { return static_cast<double>(step_) * scene_.dt; }
  const RegionTimers &timers() const { return timers_; }
  RegionTimers &timers() { return timers_; }
  const NeighborList &neighbor_list() const { return list_; }
  // Detections this rank ran since it started, and how many went through the watches
  // (kernels/neighbor_list.hpp) rather than a pass over every pair: a cost diagnostic.
  long long detections() const { return detections_; }
  long long detections_watched() const { return detections_watched_; }
  long long detections_near() const { return detections_near_; }
  Communicator &comm() { return comm_; }
  const Domain &domain() const { return domain_; }
  const BalanceOptions &balance_options() const { return balance_; }
  const BalanceRecord &balance_record() const { return balanced_; }
  const SpanningRecord &spanning_record() const { return spanning_; }
  const ExactRecord &exact_record() const { return exact_; }

  // This rank's totals since the previous call; resets them.
  IntervalTotals take_interval();
  // Collective: all ranks' totals since the last sample, without resetting them (for a
  // checkpoint). restore_interval() puts such totals back on rank 0 (zeros elsewhere): the
  // next observe() sums to the same numbers, since every total is an integer, a maximum or
  // an exact sum.
  IntervalTotals pending_interval();
  void restore_interval(const IntervalTotals &totals);
  // Collective: the order parameter, kinetic energy and the interval totals of all ranks.
  Observation observe();
  // Collective: total kinetic energy (exact sum over owned bodies of all ranks).
  double kinetic_energy();
  double target_kinetic_energy() const { return kinetic_target_; }
  // Relative kinetic-energy error the thermostat found, summed over its applications.
  const ThermostatRecord &thermostat_record() const { return thermostat_; }
  void restore_thermostat_record(const ThermostatRecord &record) { thermostat_ = record; }
  // A stop (e.g. on SIGTERM) asked by this rank before a step is agreed in that step's
  // one reduction: afterwards stop_agreed() is the same on every rank.
  void request_stop(bool stop) { stop_requested_ = stop; }
  bool stop_agreed() const { return stop_agreed_; }
  // Collective: throws the PhysicsError any rank saw in the last step but has not yet
  // reported (reports are otherwise agreed in the next step's reduction).
  void report_pending_problems();
  // Collective: the order parameter (S, director) of all bodies.
  OrderParameter order();
  // Collective: the Fourier order tensor of all bodies, each rank's bodies summed in id
  // order, ranks added in rank order (complete on rank 0; other ranks get their own share).
  // The same bits for any thread count and history on a given rank count; across rank
  // counts the sums agree to round-off (~1e-16 relative), unlike the exact sums above.
  FourierOrderTensor fourier_order(int kmax);
  // Collective: axes' angles to `director`, counted in `bins` bins of cos(theta), all ranks.
  AngularCounts angular_distribution(const Vec3 &director, int bins);
  // Collective, for debugging and tests: every id 0..n-1 is owned by exactly one rank, and
  // every shadow is a bit-identical copy of its owner's body. Throws std::logic_error.
  void verify_bodies();
  // Collective: all bodies in id order (rank 0 only; others get an empty set).
  Particles gather_bodies();
  // Collective: FNV-1a hash of ids, positions, axes, velocities and angular velocities in
  // id order (the same string on every rank).
  std::string state_checksum();

 private:
  struct Holding {
    int owner = 0;
    std::vector<int> holders;  // ranks with a shadow copy
  };

  struct Agreement {
    bool rebuild = false;   // some rank's pair list expired
    bool boundary = false;  // some rank has a contact across a rank boundary
    double largest = 0.0;   // the largest motion bound on any rank
  };

  // Construction (simulation.cpp, decomposition.cpp, balance_check.cpp).
  void configure(Particles all, ParallelOptions parallel);
  void decompose(const Particles &all, const ParallelOptions &parallel);
  Cuts starting_cuts(const Particles &all) const;
  void keep_owned(const Particles &all);
  // Bodies [0, advanced()) are moved every step: the owned ones, and the shadows the pair list
  // keeps (before the first build there are no shadows).
  std::size_t advanced() const { return list_.builds == 0 ? owned_ : list_.active; }

  // The phases of a step (simulation.cpp unless noted).
  MidpointDetection to_midpoint(int halves);        // 1 (and 2), or 6 and the next 1
  void midpoint(const MidpointDetection &reached);  // 2-5
  DetectionStats detect();                          // 2
  void note_detection(const DetectionStats &detected);
  bool touches_boundary() const;                         // decomposition.cpp
  Agreement agree(double largest_bound, bool boundary);  // 3
  void rebuild();                                        // 4, decomposition.cpp
  void take_new_cuts();                                  // decomposition.cpp
  void migrate();                                        // decomposition.cpp
  void redistribute();                                   // decomposition.cpp
  void index_bodies();                                   // decomposition.cpp
  ResolutionStats resolve(const Agreement &agreed, std::vector<char> &counted);  // 5
  ResolutionStats resolve_on_ranks(const ContactClusters &clusters, bool exchange);
  void tally(const DetectionStats &detected, const ResolutionStats &resolved,
             const std::vector<char> &counted);
  void second_half();  // 6
  // The exact method's step (runtime/exact_step.cpp): 1-6 with the collisions at their times.
  void advance_exact(long long count);
  void exact_step();
  double exact_bounds();          // 1: the step's flight in the bounds
  double exact_rebuild();         // 4, then 1 again
  bool extend_list(double lead);  // 4 without a build, where it pays (one rank)
  void check_flight(double largest, const char *what);
  double agreed_max(double value);
  DetectionStats exact_collisions(ExactStats &stats);  // 2 and 5
  void exact_flight();                                 // 6
  void tally_exact(const DetectionStats &detected, const ExactStats &stats);
  // Phase 5 of the exact step on several ranks (runtime/exact_ranks.cpp).
  ExactStats collide_on_ranks(double &reach);
  void solve_local_components(ExactRound &round, const ExactComponents &cc,
                              const std::vector<char> &changed);
  void solve_spanning_components(ExactRound &round, const ExactComponents &cc,
                                 const std::vector<char> &changed);
  std::vector<std::int64_t> exchange_pieces(ExactRound &round, const ExactComponents &cc,
                                            const std::vector<char> &changed);
  void forward_pieces(ExactRound &round, std::vector<std::int64_t> &fresh);
  void post_piece(const std::vector<ExactPieces::Body> &bodies,
                  const std::vector<ExactPieces::Edge> &edges);
  void open_messages(const std::vector<ExactResult> &results);
  void swap_pieces(ExactPieces &pieces, std::size_t first, std::vector<std::int64_t> &fresh,
                   std::vector<ExactResult> &results);
  // --results-exchange for the exact method: on two ranks, where one exchange of pieces gives
  // every rank its clusters whole (on more, pieces are forwarded instead and the switch is
  // ignored: a solver could not reach every rank that needs its results).
  bool results_path() const { return results_exchange_ && comm_.size() == 2; }
  void exchange_exact_results(ExactRound &round, const std::vector<ExactResult> &results);
  void settle_exact(ExactRound &round, std::uint32_t body, const ExactResult &result);
  void replace_exact(ExactRound &round, const ExactResult &result);
  ExactStats exact_counts(const ExactRound &round, const std::vector<FlownBody> &flown) const;
  void restore_constraints();  // 7
  void apply_thermostat();     // 7
  // 8, balance_check.cpp. Collective, every balance_.interval steps: compares the ranks'
  // loads and, past the threshold, sets new cuts for the next rebuild (forcing one when that
  // pays).
  void check_balance();

  // 5b, spanning_clusters.cpp: the clusters with local[c] == 0 (a body other ranks hold),
  // put together from every owner's contacts and resolved. Collective over partners.
  ResolutionStats resolve_across_ranks(const ContactClusters &clusters,
                                       const std::vector<char> &local);
  ClusterRecords exchange_records(const ContactClusters &clusters, const std::vector<char> &local);
  std::vector<char> clusters_to_resolve(const ClusterRecords &records, const RecordClusters &rc,
                                        const std::vector<std::size_t> &where) const;
  void note_spanning(const ClusterRecords &records, const RecordClusters &rc,
                     const std::vector<char> &take, const std::vector<char> &owned);
  void exchange_results(const ClusterRecords &records, const RecordClusters &rc,
                        const std::vector<char> &take, const std::vector<std::uint32_t> &slot,
                        const std::vector<Contact> &solved);
  void note_unresolved(const ContactClusters &clusters, const std::vector<char> &local);
  void add_targets(std::int64_t id, std::vector<int> &targets) const;
  void settle_body(std::size_t i, const double (&motion)[6]);
  void set_impulse(const Contact &solved);

  void report_problems(const std::vector<double> &flags);
  // Sums the counters and takes the maxima of `t` over ranks (steps and exact sums untouched).
  void sum_counts_over_ranks(IntervalTotals &t, const char *name);
  [[noreturn]] void fail(const std::string &message);

  Scene scene_;
  Communicator comm_;
  Domain domain_;
  Particles particles_;
  std::size_t owned_ = 0;
  std::unordered_map<std::int64_t, Holding> holding_;      // by id, for every held body
  std::unordered_map<std::int64_t, std::uint32_t> index_;  // id -> local index
  std::vector<char> shared_;  // by local index: a shadow, or an owned body held elsewhere
  NeighborList list_;
  long long detections_ = 0, detections_watched_ = 0, detections_near_ = 0;
  std::vector<Contact> contacts_;      // the midpoint method's, each step
  std::vector<Candidate> candidates_;  // the exact method's, each step
  // Bodies whose velocities a step changed (their motion constants are then due): those
  // resolve_across_ranks set, and the scratch list of all of them.
  std::vector<std::uint32_t> shared_in_, changed_;
  SolverSettings solver_;
  RegionTimers timers_;
  IntervalTotals interval_;
  ThermostatRecord thermostat_;
  double kinetic_target_ = 0.0;
  long long step_ = 0;
  // A problem seen by this rank, reported collectively at the next agreement.
  double pending_depth_ = 0.0;
  double pending_unresolved_ = 0.0;
  long long pending_step_ = 0;
  bool stop_requested_ = false;
  bool stop_agreed_ = false;
  BalanceOptions balance_;
  BalanceRecord balanced_;
  SpanningRecord spanning_;
  ExactSettings exact_settings_;
  ExactScratch exact_scratch_;
  std::vector<FlownBody> flown_;
  ExactProblem exact_problem_;  // the spanning clusters solved here (exact_ranks.cpp)
  ExactRecord exact_;
  // Scratch of resolve_across_ranks, kept between steps so that a step allocates nothing:
  // by local index, whether a body got its velocities this step (all 0 between calls); the
  // bodies of the clusters it resolves; its outgoing messages.
  std::vector<char> settled_;
  Particles spanning_bodies_;
  std::vector<std::vector<char>> spanning_out_;
  bool results_exchange_ = false;  // ParallelOptions::results_exchange
  bool extend_lists_ = true;       // ParallelOptions::extend_lists
  double busy_mark_ = 0.0;         // compute seconds at the last balance check
  Cuts pending_cuts_;              // new cuts for the next rebuild (empty: none)
  bool force_rebuild_ = false;
  GrownBounds grown_;  // exact_bounds: what the step's flight made of the bounds
};

}  // namespace hardrod
