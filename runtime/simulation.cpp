#include "runtime/simulation.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numeric>

#include "kernels/contact_detection.hpp"
#include "kernels/initial_state.hpp"
#include "kernels/integrator.hpp"
#include "kernels/thermostat.hpp"

namespace hardrod {

Simulation::Simulation(Scene scene) : scene_(std::move(scene)) {
  place_on_lattice(particles_, scene_.box, scene_.lattice, scene_.axis);
  assign_velocities(particles_, scene_.shape, scene_.seed, scene_.temperature);
  configure();
}

Simulation::Simulation(Scene scene, Particles bodies)
    : scene_(std::move(scene)), particles_(std::move(bodies)) {
  if (static_cast<long long>(particles_.size()) != scene_.n)
    throw std::invalid_argument(fmt::format("Simulation: {} bodies given for a scene of n = {}",
                                            particles_.size(), scene_.n));
  configure();
}

void Simulation::configure() {
  kinetic_target_ = hardrod::target_kinetic_energy(scene_.n, scene_.shape, scene_.temperature);
  list_.skin = scene_.skin;
  solver_.tolerance = scene_.solver_tolerance;
  solver_.max_iterations = static_cast<int>(scene_.solver_max_iterations);
}

void Simulation::step() {
  const double half_dt = 0.5 * scene_.dt;
  const std::size_t n = particles_.size();
  const Shape &shape = scene_.shape;

  {  // 1. first half: free flight to the midpoint
    ScopedRegion r(timers_, Region::kIntegrate);
    half_step(particles_, n, shape, half_dt);
  }
  if (neighbor_list_expired(list_, particles_, n)) {
    ScopedRegion r(timers_, Region::kNeighborBuild);
    build_neighbor_list(list_, particles_, n, scene_.box, shape);
  }
  DetectionStats detected;
  {  // 2. contacts at the midpoint
    ScopedRegion r(timers_, Region::kDetect);
    detected = detect_contacts(particles_, scene_.box, shape, list_, contacts_);
  }
  if (!(detected.max_depth <= scene_.max_overlap))
    throw PhysicsError(fmt::format(
        "step {}: overlap depth {:.4g} D exceeds run.max_overlap = {:g} D at run.dt = {:g}; "
        "the time step is too large for these velocities, try run.dt = {:g}",
        step_ + 1, detected.max_depth, scene_.max_overlap, scene_.dt, scene_.dt / 4));
  ResolutionStats resolved;
  {  // 3. elastic impulses
    ScopedRegion r(timers_, Region::kResolve);
    resolved = resolve_contacts(particles_, shape, contacts_, solver_);
  }
  {  // 4. second half
    ScopedRegion r(timers_, Region::kIntegrate);
    half_step(particles_, n, shape, half_dt, &scene_.box);
  }
  ++step_;

  interval_.steps += 1;
  interval_.collisions += resolved.collisions;
  interval_.narrow_phase_tests += detected.narrow_phase_tests;
  interval_.contacts += static_cast<long long>(contacts_.size());
  interval_.multi_contact_bodies += resolved.multi_contact_bodies;
  interval_.clusters += resolved.clusters;
  interval_.solver_iterations_max =
      std::max(interval_.solver_iterations_max, resolved.iterations_max);
  interval_.solver_unconverged += resolved.unconverged;
  interval_.max_depth = std::max(interval_.max_depth, detected.max_depth);
  interval_.solver_energy_change += resolved.energy_change;
  interval_.virial += resolved.virial;

  if (scene_.thermostat_interval > 0 && step_ % scene_.thermostat_interval == 0) {
    ScopedRegion r(timers_, Region::kThermostat);
    apply_thermostat();
  }
}

void Simulation::apply_thermostat() {
  const std::size_t n = particles_.size();
  project_angular_velocities(particles_, n);
  const double ke = kinetic_energy();
  if (!std::isfinite(ke) || ke <= 0.0)
    throw PhysicsError(fmt::format(
        "step {}: kinetic energy is {} (NaN or infinite velocities) at run.dt = {:g}; "
        "try a smaller run.dt",
        step_, ke, scene_.dt));
  thermostat_corrections_.push_back(ke / kinetic_target_ - 1.0);
  scale_velocities(particles_, n, std::sqrt(kinetic_target_ / ke));
}

IntervalTotals Simulation::take_interval() {
  IntervalTotals out = interval_;
  interval_ = IntervalTotals{};
  return out;
}

double Simulation::kinetic_energy() const {
  return hardrod::kinetic_energy(particles_, particles_.size(), scene_.shape).total();
}

double Simulation::temperature() const {
  const double dof =
      static_cast<double>(scene_.shape.degrees_of_freedom()) * static_cast<double>(scene_.n) - 3.0;
  return 2.0 * kinetic_energy() / dof;
}

std::string Simulation::state_checksum() const {
  const Particles &p = particles_;
  std::vector<std::size_t> order(p.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p.id[a] < p.id[b]; });
  std::uint64_t hash = 1469598103934665603ULL;  // FNV-1a 64
  auto feed = [&hash](const void *data, std::size_t bytes) {
    const auto *c = static_cast<const unsigned char *>(data);
    for (std::size_t k = 0; k < bytes; ++k) {
      hash ^= c[k];
      hash *= 1099511628211ULL;
    }
  };
  for (std::size_t i : order) {
    feed(&p.id[i], sizeof(std::int64_t));
    for (const auto *field : {&p.x, &p.y, &p.z, &p.ex, &p.ey, &p.ez, &p.vx, &p.vy, &p.vz, &p.wx,
                              &p.wy, &p.wz})
      feed(&(*field)[i], sizeof(double));
  }
  return fmt::format("{:016x}", hash);
}

}  // namespace hardrod
