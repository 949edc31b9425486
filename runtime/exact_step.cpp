// The exact method's time step (run.method = "exact", docs/physics.md section 3b): the phases of
// simulation.hpp with the collisions at their exact times inside the step instead of at its
// midpoint. The bodies stay at the step's start until the collisions are known:
//   1. the motion bounds grow by the step's free flight (grow_bounds), before anything moves
//   3. agree: the list expires when those bounds reach the skin (then 4. rebuild); on one
//      rank body by body, each body's reach extended before the list is built again
//      (kernels/list_extension.hpp)
//   2. detect: the listed pairs that could touch within the step (detect_contacts, `ahead`)
//   5. collide: each cluster of them event by event (kernels/exact_collisions.hpp)
//   6. flight: every body by dt (fly_step), the bodies whose velocity changed to their own end
//      states (land_flown)
//   7, 8 as for the midpoint method.
// On several ranks phase 5 runs in rounds agreed between ranks (runtime/exact_ranks.cpp), and
// every failure is agreed first, so that all ranks stop together.
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "kernels/list_extension.hpp"
#include "kernels/rotor_constraints.hpp"
#include "runtime/simulation.hpp"

namespace hardrod {

namespace {

// The one queue's overrun allowance per unit of dt (D per tau): a body whose velocity changes
// has its listed pairs checked only once its overrun passes this speed times dt, and the
// detection hands the queue the pairs within it as spares. Hard spheres at N = 32768, dt 4e-3,
// skin 0.5, in turns (docs/performance.md), the step's time over its list builds' (which the
// allowance leaves alone, the machine's load does not): 0 / 0.25 / 0.5 / 0.75 / 1 / 2 cost
// 5.9 / 5.3 / 5.1 / 5.1 / 5.2 / 5.5 (the resolve alone 3.1 -> 2.2-2.3 at 0.5 to 0.75, the
// detection 1.29 -> 1.35-1.42); the everyday nematic is about even from 0 to 2.
constexpr double kOverrunAllowanceSpeed = 0.75;

// A list's bodies are extended (kernels/list_extension.hpp) up to one extension per
// kExtensionShare bodies, then it is built again; a body is extended once its bound is within
// kExtensionLead of the fastest body's step of its reach, so that one that speeds up within
// the step seldom outruns it there (which has the step solved again on a new list). Hard
// spheres at N = 32768, dt 4e-3, skin 0.5, 1250 steps (docs/performance.md): 96 builds
// without extensions; with a share of 1024 / 512 / 256, 79 / 76 / 71 builds and 1796 / 3398 /
// 7190 extensions; a lead of 0 had 7 steps solved again (share 512), 0.5 none. The everyday
// nematic (N = 2304) saves 3 of 48 builds at 256.
constexpr long long kExtensionShare = 256;
constexpr double kExtensionLead = 0.5;

}  // namespace

void Simulation::advance_exact(long long count) {
  {
    ScopedRegion r(timers_, Region::kIntegrate);
    refresh_motion(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
  }
  for (long long k = 0; k < count; ++k) {
    exact_step();
    ++step_;
    if (step_ % kConstraintInterval == 0) restore_constraints();                    // 7.
    if (scene_.thermostat_interval > 0 && step_ % scene_.thermostat_interval == 0)  // 7.
      apply_thermostat();
    if (stop_agreed_) return;
  }
}

// One step; positions at its start until 6.
void Simulation::exact_step() {
  double largest = exact_bounds();           // 1.
  Agreement agreed = agree(largest, false);  // 3.
  check_flight(agreed.largest, "a velocity is NaN or infinite");
  // One rank: the list expires body by body, extended first (a list for other bodies, or none
  // yet, is built). Where none can be extended (past the budget), built once a body reached
  // its reach.
  if (extend_lists_ && comm_.size() == 1 && !force_rebuild_ &&
      !neighbor_list_expired(list_, 0.0, particles_.size())) {
    const double lead = kExtensionLead * grown_.fastest_step, half = 0.5 * scene_.skin;
    agreed.rebuild =
        grown_.largest_used + lead >= half && !extend_list(lead) && grown_.largest_used >= half;
  }
  if (force_rebuild_) {
    agreed.rebuild = true;
    force_rebuild_ = false;
  }
  if (agreed.rebuild) {  // 4.
    largest = agreed_max(exact_rebuild());
    check_flight(largest, "a body's flight in one step");
    if (neighbor_list_expired(list_, largest, particles_.size()))
      fail(
          fmt::format("step {}: at run.dt = {:g} a body's flight in one step ({:.4g} D) is more "
                      "than half the neighbour-list skin (run.skin = {:g}); use a smaller "
                      "run.dt or a larger run.skin",
                      step_ + 1, scene_.dt, largest, scene_.skin));
  }
  ExactStats stats;
  const DetectionStats detected = exact_collisions(stats);  // 2., 5.
  exact_flight();                                           // 6.
  tally_exact(detected, stats);
}

// The bodies' bounds grown by the step's flight; the largest (+infinity for a NaN or an
// infinite velocity, which shows here first), checked by the caller once agreed.
double Simulation::exact_bounds() {
  ScopedRegion r(timers_, Region::kIntegrate);
  const std::size_t n = advanced();
  // Extra reaches only once a body was extended since the build (list_extension.hpp).
  const bool extra = list_.extended > 0 && list_.extra_reach.size() >= n;
  grown_ = grow_bounds(particles_, n, extra ? list_.extra_reach.data() : nullptr);
  const double largest = grown_.largest;
  return std::isfinite(largest) ? largest : std::numeric_limits<double>::infinity();
}

// Phase 4, and the step's flight in the new list's bounds; shadows come without their motion
// constants.
double Simulation::exact_rebuild() {
  rebuild();
  {
    ScopedRegion r(timers_, Region::kIntegrate);
    refresh_motion(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
  }
  return exact_bounds();
}

// Phase 4 without a build (kernels/list_extension.hpp): on one rank, the bodies whose bound
// came within `lead` of their reach get more of it and their new partners, up to one
// extension per kExtensionShare bodies in a list's life. False where the list is to be built
// instead.
bool Simulation::extend_list(double lead) {
  ScopedRegion r(timers_, Region::kNeighborBuild);
  const long long budget = static_cast<long long>(list_.active) / kExtensionShare;
  return extend_neighbor_list(list_, particles_, scene_.box, scene_.shape, lead, budget);
}

// An agreed bound that is not finite stops the run: never fly on with NaN.
void Simulation::check_flight(double largest, const char *what) {
  if (!std::isfinite(largest))
    fail(fmt::format("step {}: {} (motion bound {}) at run.dt = {:g}", step_ + 1, what, largest,
                     scene_.dt));
}

// The largest of `value` over ranks.
double Simulation::agreed_max(double value) {
  if (comm_.size() == 1) return value;
  ScopedRegion r(timers_, Region::kAgree);
  return comm_.max("agree", {value})[0];
}

// Phases 2 and 5. A body whose velocity changed may outrun the flight its bound was grown by;
// if that carries it past the list's skin, a pair the list does not hold could have touched:
// the step is solved again on a list built now (the bodies have not moved yet).
DetectionStats Simulation::exact_collisions(ExactStats &stats) {
  // One thread takes the events of a step (on several ranks: of the clusters it owns whole) in
  // one queue; a team solves clusters in parallel (the same bits). Everyday nematic,
  // equilibrated, dt 1e-3: one thread 108.5 -> 92.0 us per rod per tau with the queue; two
  // threads 88-109 ns per rod-step by cluster against 99-112 in the queue
  // (docs/performance.md). One rank's queue takes the spares of an overrun allowance
  // (kOverrunAllowanceSpeed); ranks leave them out of their clusters' protocol.
  exact_settings_.one_queue = omp_get_max_threads() == 1;
  exact_settings_.overrun_allowance =
      exact_settings_.one_queue && comm_.size() == 1 ? kOverrunAllowanceSpeed * scene_.dt : 0.0;
  for (int attempt = 0;; ++attempt) {
    DetectionStats detected;
    {
      ScopedRegion r(timers_, Region::kDetect);
      const StepAhead ahead{particles_.grow.data(), scene_.dt, comm_.size() > 1,
                            exact_settings_.overrun_allowance};
      detected = detect_contacts(particles_, scene_.box, scene_.shape, list_, candidates_, ahead);
      note_detection(detected);
    }
    double reach = 0.0;
    {
      ScopedRegion r(timers_, Region::kResolve);
      if (comm_.size() > 1) {
        stats = collide_on_ranks(reach);
      } else {
        stats = collide_exactly(particles_, scene_.box, scene_.shape, list_, candidates_, scene_.dt,
                                exact_settings_, exact_scratch_, flown_);
        for (const FlownBody &f : flown_)  // against half the skin: less its extra reach
          reach = std::max(
              reach, particles_.motion_bound[f.body] + f.overrun - extra_reach(list_, f.body));
      }
    }
    if (!neighbor_list_expired(list_, reach, particles_.size())) return detected;
    if (attempt > 0)
      fail(
          fmt::format("step {}: at run.dt = {:g} a body's flight after a collision ({:.4g} D) "
                      "is more than half the neighbour-list skin (run.skin = {:g}); use a "
                      "smaller run.dt or a larger run.skin",
                      step_ + 1, scene_.dt, reach, scene_.skin));
    ++exact_.rebuilt_in_step;
    exact_rebuild();  // the same bounds as before the rebuild: checked then
  }
}

// Phase 6: every body flies the whole step; those whose velocity changed land on the end
// states of their own flights, and their motion constants follow their new velocities.
void Simulation::exact_flight() {
  ScopedRegion r(timers_, Region::kIntegrate);
  fly_step(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
  land_flown(particles_, flown_, !scene_.shape.is_sphere());
  changed_.clear();
  for (const FlownBody &f : flown_) changed_.push_back(f.body);
  refresh_motion(particles_, changed_, scene_.shape, 0.5 * scene_.dt);
}

void Simulation::tally_exact(const DetectionStats &detected, const ExactStats &stats) {
  interval_.steps += 1;
  interval_.collisions += stats.collisions;
  interval_.virial += stats.virial;
  interval_.narrow_phase_tests += detected.narrow_phase_tests;
  // The exact method's clusters are counted in summary.json's `exact` block only: steps taken in
  // one queue form none, so they are not the midpoint method's multi-contact clusters.
  interval_.contacts += stats.candidates;
  interval_.max_depth = std::max(interval_.max_depth, detected.max_depth);
  ++exact_.steps;
  exact_.totals += stats;
}

}  // namespace hardrod
