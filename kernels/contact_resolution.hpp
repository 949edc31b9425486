// Elastic, frictionless impulse resolution of the contacts of one time step
// (SPEC.md section 4). Contacts are grouped into clusters that share bodies. A lone contact
// gets the exact impulse J = -2u/k when approaching (u < 0), which conserves momentum,
// angular momentum and kinetic energy. A cluster is solved by projected Gauss-Seidel on
// accumulated impulses lambda >= 0 with target u' >= -u0 (approaching) or u' >= 0 (already
// receding), in canonical contact order, to a relative tolerance. Each impulse adds
// J n . (x_i - x_j) to the collision virial. Reads/writes velocities and angular velocities
// of contact bodies. Threads take whole clusters, so no body is written by two threads and
// the result does not depend on the thread count.
#pragma once

#include <vector>

#include "kernels/contact.hpp"
#include "kernels/exact_sum.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

struct SolverSettings {
  double tolerance = 1e-10;  // on the velocity residual, relative to the largest |u0|
  int max_iterations = 1000;
};

struct ResolutionStats {
  long long collisions = 0;              // contacts that received an impulse
  long long clusters = 0;                // clusters with more than one contact
  long long multi_contact_bodies = 0;    // bodies with more than one contact
  long long iterations_max = 0;          // largest Gauss-Seidel iteration count
  long long unconverged = 0;             // clusters that hit max_iterations
  double energy_change = 0.0;            // kinetic energy change of the clusters (>1 contact)
  ExactSum virial;                       // sum of J n . (x_i - x_j)
};

ResolutionStats resolve_contacts(Particles &p, const Shape &shape, std::vector<Contact> &contacts,
                                 const SolverSettings &settings);

// Relative normal velocity u = n . ((v_i + w_i x r_i) - (v_j + w_j x r_j)).
double normal_velocity(const Particles &p, const Contact &c);

}  // namespace hardrod
