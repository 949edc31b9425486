// The state of a run and one time step (SPEC.md section 3). `step()` reads like the
// algorithm: half step, (re)build the pair list if it expired, detect, resolve, half step,
// thermostat; each phase a named, timed call into kernels/. Physics that breaks (overlap
// beyond run.max_overlap, NaN) throws PhysicsError naming the step and dt.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "kernels/contact.hpp"
#include "kernels/contact_resolution.hpp"
#include "kernels/exact_sum.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/particles.hpp"
#include "perf/region_timer.hpp"
#include "runtime/scene.hpp"

namespace hardrod {

class PhysicsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Running totals since the last call to Simulation::take_interval().
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
  double solver_energy_change = 0.0;
  ExactSum virial;  // sum of J n . (x_i - x_j)
};

class Simulation {
 public:
  // Starts from the scene's lattice with fresh velocities.
  explicit Simulation(Scene scene);
  // Starts from given bodies (a snapshot, or another run's state); n must match the scene.
  Simulation(Scene scene, Particles bodies);

  void step();

  const Scene &scene() const { return scene_; }
  const Particles &particles() const { return particles_; }
  Particles &particles() { return particles_; }
  std::size_t body_count() const { return particles_.size(); }
  long long current_step() const { return step_; }
  double time() const { return static_cast<double>(step_) * scene_.dt; }
  const RegionTimers &timers() const { return timers_; }
  RegionTimers &timers() { return timers_; }
  const NeighborList &neighbor_list() const { return list_; }

  // Totals accumulated since the previous call; resets them.
  IntervalTotals take_interval();
  // Current kinetic energy (exact sum) and the thermostat's target.
  double kinetic_energy() const;
  double target_kinetic_energy() const { return kinetic_target_; }
  // Instantaneous temperature from the kinetic energy, kT = 2 KE / (dof N - 3).
  double temperature() const;
  // Relative kinetic-energy error each thermostat application found (drift record).
  const std::vector<double> &thermostat_corrections() const { return thermostat_corrections_; }
  // FNV-1a hash of ids, positions, axes, velocities and angular velocities in id order.
  std::string state_checksum() const;

 private:
  void configure();
  void apply_thermostat();

  Scene scene_;
  Particles particles_;
  NeighborList list_;
  std::vector<Contact> contacts_;
  SolverSettings solver_;
  RegionTimers timers_;
  IntervalTotals interval_;
  std::vector<double> thermostat_corrections_;
  double kinetic_target_ = 0.0;
  long long step_ = 0;
};

}  // namespace hardrod
