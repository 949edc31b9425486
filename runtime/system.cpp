// The System (runtime/system.hpp): construction, the schedule of the steps (the method's
// phases, then 7 and 8), the step's one agreement (3) and the problems reported on every rank,
// the rotor constraints and the thermostat. The other phases' System parts have their own
// files: decomposition.cpp (4), balance_check.cpp (8); observables and diagnostics too.
#include "runtime/system.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "kernels/free_flight.hpp"
#include "kernels/rotor_constraints.hpp"
#include "kernels/thermostat.hpp"
#include "runtime/start.hpp"
#include "runtime/step_method.hpp"

namespace hardrod {

// A lattice start is made where it is owned (start_on_lattice); the others are made whole on
// every rank, which keeps its share.
System::System(Scene scene, ParallelOptions parallel) : scene_(std::move(scene)) {
  configure(parallel);
  if (scene_.configuration == Configuration::kLattice)
    start_on_lattice(parallel);
  else
    decompose_all(
        initial_bodies(scene_, comm_.size() == 1, parallel.report_setup && comm_.is_root()),
        parallel);
}

System::System(Scene scene, Particles bodies, ParallelOptions parallel, long long first_step)
    : scene_(std::move(scene)), step_(first_step) {
  if (static_cast<long long>(bodies.size()) != scene_.n)
    throw std::invalid_argument(
        fmt::format("System: {} bodies given for a scene of n = {}", bodies.size(), scene_.n));
  configure(parallel);
  decompose_all(bodies, parallel);
}

System::~System() = default;

void System::configure(const ParallelOptions &parallel) {
  kinetic_target_ = hardrod::target_kinetic_energy(scene_.n, scene_.shape, scene_.temperature);
  list_.skin = scene_.skin;
  balance_ = parallel.balance;
  if (balance_.interval < 1)
    throw SceneError(
        {fmt::format("--balance-interval must be at least 1, got {}", balance_.interval)});
  method_ = make_step_method(scene_, parallel, comm_.size());
}

void System::fail(const std::string &message) const { throw PhysicsError(message); }

void System::step() { advance(1); }

// Steps in a row: the method's phases, then 7 and 8 where due. Between two steps of one call
// nothing reads the state, so a method may run the second half of a step and the first half of
// the next as one pass (`next_follows`), except where the rotor constraints or the thermostat
// act between them, or a stop was agreed.
void System::advance(long long count) {
  // The methods read each body's motion constants: current from here on, whatever changed the
  // velocities since the last call. Within the call they follow every change.
  refresh_all_motion();
  for (long long k = 0; k < count; ++k) {
    method_->step(*this);  // 1.-5.
    ++step_;
    const bool constrain = step_ % kConstraintInterval == 0;
    const bool thermostat =
        scene_.thermostat_interval > 0 && step_ % scene_.thermostat_interval == 0;
    method_->finish(*this, k + 1 < count && !constrain && !thermostat && !stop_agreed_);  // 6.
    if (constrain) restore_constraints();                                                 // 7.
    if (thermostat) apply_thermostat();                                                   // 7.
    if (stop_agreed_) return;
    if (balance_.mode != BalanceMode::kOff && comm_.size() > 1 && step_ % balance_.interval == 0)
      check_balance();  // 8.
  }
}

void System::refresh_all_motion() {
  ScopedRegion r(timers_, Region::kIntegrate);
  refresh_motion(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
}

// Phase 7: the rotors' constraints (unit axis, w perpendicular to it) against round-off.
void System::restore_constraints() {
  ScopedRegion r(timers_, Region::kIntegrate);
  restore_rotor_constraints(particles_, advanced());
  refresh_motion(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
}

// Phase 7: velocities scaled to the target kinetic energy.
void System::apply_thermostat() {
  ScopedRegion r(timers_, Region::kThermostat);
  const double ke = kinetic_energy();
  if (!std::isfinite(ke) || ke <= 0.0)
    fail(
        fmt::format("step {}: kinetic energy is {} (NaN or infinite velocities) at run.dt = {:g}; "
                    "try a smaller run.dt",
                    step_, ke, scene_.dt));
  thermostat_.correction_sum += ke / kinetic_target_ - 1.0;
  ++thermostat_.applications;
  // Shadows are scaled too, by the same factor: they stay bit-identical to their owners.
  scale_velocities(particles_, particles_.size(), std::sqrt(kinetic_target_ / ke));
  refresh_motion(particles_, advanced(), scene_.shape, 0.5 * scene_.dt);
}

// One max-reduction per step: whether any rank's pair list expired, whether any rank has a
// contact across a rank boundary, any problem a rank saw (so that every rank stops together)
// and a stop asked for by a signal.
Agreement System::agree(double largest_bound, bool boundary) {
  std::vector<double> flags{largest_bound,
                            pending_depth_,
                            pending_unresolved_,
                            static_cast<double>(pending_step_),
                            stop_requested_ ? 1.0 : 0.0,
                            boundary ? 1.0 : 0.0};
  if (comm_.size() > 1) {
    ScopedRegion r(timers_, Region::kAgree);
    flags = comm_.max("agree", flags);
  }
  stop_agreed_ = flags[4] > 0.0;
  report_problems(flags);
  return {neighbor_list_expired(list_, flags[0], particles_.size()), flags[5] > 0.0, flags[0]};
}

double System::agreed_max(double value) {
  if (comm_.size() == 1) return value;
  ScopedRegion r(timers_, Region::kAgree);
  return comm_.max("agree", {value})[0];
}

bool System::take_forced_rebuild() {
  if (!force_rebuild_) return false;
  force_rebuild_ = false;
  ++balanced_.forced_rebuilds;
  return true;
}

void System::note_detection(const DetectionStats &detected) {
  ++detections_;
  detections_watched_ += detected.watched;
  detections_near_ += detected.near;
  if (!(detected.max_depth <= scene_.max_overlap)) {
    pending_depth_ = std::isnan(detected.max_depth) ? 1e300 : detected.max_depth;
    pending_step_ = step_ + 1;
  }
}

void System::note_unresolved(double contacts) {
  pending_unresolved_ = std::max(pending_unresolved_, contacts);
  pending_step_ = step_ + 1;
}

void System::report_pending_problems() {
  std::vector<double> flags{0.0, pending_depth_, pending_unresolved_,
                            static_cast<double>(pending_step_)};
  if (comm_.size() > 1) flags = comm_.max("agree", flags);
  report_problems(flags);
}

// flags: [1] deepest overlap beyond the tolerance, [2] unresolvable cluster, [3] its step.
void System::report_problems(const std::vector<double> &flags) {
  if (flags[1] > 0.0)
    fail(fmt::format(
        "step {}: overlap depth {:.4g} D exceeds run.max_overlap = {:g} D at run.dt = {:g}; "
        "the time step is too large for these velocities, try run.dt = {:g}",
        static_cast<long long>(flags[3]), flags[1] >= 1e300 ? NAN : flags[1], scene_.max_overlap,
        scene_.dt, scene_.dt / 4));
  if (flags[2] > 0.0)
    fail(fmt::format(
        "step {}: a cluster of touching bodies across ranks ({} contacts seen by its owner) "
        "reached no rank that holds it in full, so it was not resolved; run with fewer ranks "
        "(larger subdomains) or a smaller run.dt (now {:g})",
        static_cast<long long>(flags[3]), static_cast<long long>(flags[2]), scene_.dt));
}

}  // namespace hardrod
