// The state of a run and the schedule of its steps (docs/physics.md sections 3 and 7). The
// phases of one step, numbered once here for every file:
//   1. first half: free flight (midpoint: to the step's midpoint; exact: the motion bounds grow
//      by the step's flight before anything moves)
//   2. detect: the listed pairs that touch (midpoint) or could touch within the step (exact)
//   3. agree: the step's one max-reduction: a pair list expired, a contact across a rank
//      boundary, problems, a stop (System::agree)
//   4. rebuild when due: new cuts, migration, shadows, the pair list (System::rebuild,
//      runtime/decomposition.cpp), then phase 2 again
//   5. resolve: the impulses (midpoint: at the midpoint, by cluster; exact: every collision at
//      its time), (a) of the clusters this rank holds in full, (b) of those across ranks
//   6. second half: free flight to the end of the step (midpoint: fused with the next step's
//      phase 1 where nothing acts between them)
//   7. when due: the rotor constraints and the thermostat (System::advance)
//   8. when due: the load balance check (System::check_balance, runtime/balance_check.cpp)
// The System owns the bodies, their decomposition over ranks, the agreement, the schedule of
// phases 7 and 8, observables and diagnostics; the step method (runtime/step_method.hpp),
// chosen once at construction, runs phases 1, 2, 5 and 6 and calls back into phases 3 and 4.
// Each phase is a named, timed call; every communication step is a named, counted call into
// runtime/comm. One rank runs the same code with no partners. Physics that breaks (overlap
// beyond run.max_overlap, NaN) throws PhysicsError naming the step and dt, on every rank.
// Observables are in runtime/observables.cpp, the checksum and checks in
// runtime/diagnostics.cpp.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "kernels/contact_detection.hpp"
#include "kernels/exact_sum.hpp"
#include "kernels/fourier_order_tensor.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/order_tensor.hpp"
#include "kernels/particles.hpp"
#include "perf/region_timer.hpp"
#include "runtime/balance.hpp"
#include "runtime/comm.hpp"
#include "runtime/domain.hpp"
#include "runtime/scene.hpp"

namespace hardrod {

class StepMethod;

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
  // (kernels/exact/list_extension.hpp): the same trajectory. False builds it at every expiry
  // (tests, comparisons).
  bool extend_lists = true;
  // Rank 0 prints the progress of a long set-up (the isotropic compression).
  bool report_setup = false;
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

// Running totals since the last call to System::take_interval(), for this rank's share
// (contacts are counted by the rank that owns their lower-id body).
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

// What phase 3 agreed, the same on every rank.
struct Agreement {
  bool rebuild = false;   // some rank's pair list expired
  bool boundary = false;  // some rank has a contact across a rank boundary
  double largest = 0.0;   // the largest motion bound on any rank
};

class System {
 public:
  // Starts from the scene's initial bodies (runtime/start.hpp).
  explicit System(Scene scene, ParallelOptions parallel = {});
  // Starts from given bodies (all n of them, on every rank; each keeps its own) at step
  // `first_step` (a restart: the step number keys the thermostat and constraint schedule).
  System(Scene scene, Particles bodies, ParallelOptions parallel = {}, long long first_step = 0);
  ~System();
  System(const System &) = delete;
  System &operator=(const System &) = delete;

  void step();
  // `count` steps, bit for bit the same as `count` calls of step() but faster where the method
  // fuses two half steps into one pass between steps; returns early after a step that agreed
  // to stop.
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
  const StepMethod &method() const { return *method_; }
  // Detections this rank ran since it started, and how many went through the watches
  // (kernels/neighbor_list.hpp) or the near pairs rather than a pass over every pair: a cost
  // diagnostic.
  long long detections() const { return detections_; }
  long long detections_watched() const { return detections_watched_; }
  long long detections_near() const { return detections_near_; }
  Communicator &comm() { return comm_; }
  const Domain &domain() const { return domain_; }
  const BalanceOptions &balance_options() const { return balance_; }
  const BalanceRecord &balance_record() const { return balanced_; }

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

  // What a step method (runtime/step_method.hpp) works on and calls back into.
  // Bodies [0, advanced()) are moved every step: the owned ones, and the shadows the pair list
  // keeps (before the first build there are no shadows).
  std::size_t advanced() const { return list_.builds == 0 ? owned_ : list_.active; }
  NeighborList &list() { return list_; }
  // By local index: a shadow, or an owned body that other ranks hold (after a rebuild).
  const std::vector<char> &shared() const { return shared_; }
  // Body `id`'s local index where this rank advances it, else kNotAdvanced.
  static constexpr std::size_t kNotAdvanced = static_cast<std::size_t>(-1);
  std::size_t advanced_index(std::int64_t id) const;
  // The ranks other than this one that own or hold body `id` (if this rank holds it), added to
  // `targets`.
  void add_targets(std::int64_t id, std::vector<int> &targets) const;
  // Who owns body `id` and which other ranks hold it (shadow copies), where this rank holds it;
  // else nullptr.
  struct Holding {
    int owner = 0;
    std::vector<int> holders;  // ranks with a shadow copy
    bool has(int rank) const {
      return owner == rank || std::find(holders.begin(), holders.end(), rank) != holders.end();
    }
  };
  const Holding *holding(std::int64_t id) const;
  // Phase 3: one max-reduction of this rank's largest motion bound and boundary flag with the
  // problems and the stop asked for.
  Agreement agree(double largest_bound, bool boundary);
  // The largest of `value` over ranks (counted as `agree`).
  double agreed_max(double value);
  // True once after the load balancer set new cuts that want a rebuild now (the same on
  // every rank): the step then rebuilds.
  bool take_forced_rebuild();
  void rebuild();  // 4, runtime/decomposition.cpp
  // The motion constants of the advanced bodies, after a rebuild or any change of many
  // velocities (timed as integrate).
  void refresh_all_motion();
  // A detection's counts; an overlap beyond the tolerance (or NaN) is kept for the agreement.
  void note_detection(const DetectionStats &detected);
  // A cluster of `contacts` contacts with an owned body that no rank resolved: an error for
  // the next agreement.
  void note_unresolved(double contacts);
  IntervalTotals &interval() { return interval_; }
  [[noreturn]] void fail(const std::string &message) const;

 private:
  // Construction (system.cpp, decomposition.cpp, balance_check.cpp). SlabCounts: the bodies
  // per slab of the given cuts along an axis, for the starting cuts.
  using SlabCounts = std::function<std::vector<double>(int axis, const std::vector<double> &cuts)>;
  void configure(const ParallelOptions &parallel);
  std::array<int, 3> choose_grid(const ParallelOptions &parallel, const OrderParameter &q) const;
  void decompose(const std::array<int, 3> &grid, const SlabCounts &counts);
  void decompose_all(const Particles &all, const ParallelOptions &parallel);
  void start_on_lattice(const ParallelOptions &parallel);
  Cuts starting_cuts(const SlabCounts &counts) const;
  void keep_owned(const Particles &all);
  // Phase 4's parts (decomposition.cpp).
  void take_new_cuts();
  void migrate();
  void redistribute();
  void index_bodies();
  // Phase 7.
  void restore_constraints();
  void apply_thermostat();
  // 8, balance_check.cpp. Collective, every balance_.interval steps: compares the ranks'
  // loads and, past the threshold, sets new cuts for the next rebuild (forcing one when that
  // pays).
  void check_balance();

  void report_problems(const std::vector<double> &flags);
  // Sums the counters and takes the maxima of `t` over ranks (steps and exact sums untouched).
  void sum_counts_over_ranks(IntervalTotals &t, const char *name);

  Scene scene_;
  Communicator comm_;
  Domain domain_;
  Particles particles_;
  std::size_t owned_ = 0;
  std::unordered_map<std::int64_t, Holding> holding_;      // by id, for every held body
  std::unordered_map<std::int64_t, std::uint32_t> index_;  // id -> local index
  std::vector<char> shared_;  // by local index: a shadow, or an owned body held elsewhere
  NeighborList list_;
  std::unique_ptr<StepMethod> method_;
  long long detections_ = 0, detections_watched_ = 0, detections_near_ = 0;
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
  double busy_mark_ = 0.0;  // compute seconds at the last balance check
  Cuts pending_cuts_;       // new cuts for the next rebuild (empty: none)
  bool force_rebuild_ = false;
};

}  // namespace hardrod
