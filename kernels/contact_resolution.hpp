// Elastic, frictionless impulse resolution of the contacts of one time step
// (docs/physics.md section 4). Contacts are grouped into clusters that share bodies. A lone contact
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

// Contacts grouped into clusters that share bodies (union-find over this step's contacts).
struct ContactClusters {
  std::vector<std::uint32_t> bodies;  // local indices of all contact bodies, sorted, unique
  std::vector<std::uint32_t> degree;  // contacts per body, parallel to `bodies`
  std::vector<std::uint32_t> order;   // contact indices grouped by cluster, canonical inside
  std::vector<std::size_t> start;     // cluster c is order[start[c] .. start[c + 1])
  long long multi_contact_bodies = 0;

  std::size_t count() const { return start.empty() ? 0 : start.size() - 1; }
  // Position of local body b in `bodies`, or bodies.size() if it has no contact.
  std::size_t find(std::uint32_t b) const;
};

ContactClusters find_clusters(const std::vector<Contact> &contacts);

struct ResolutionStats {
  long long clusters = 0;        // resolved clusters with more than one contact
  long long iterations_max = 0;  // largest Gauss-Seidel iteration count
  long long unconverged = 0;     // clusters that hit max_iterations
  double energy_change = 0.0;    // kinetic energy change of the clusters (> 1 contact)
};

// Resolves the clusters with active[c] != 0 (all clusters when `active` is empty), writing
// each contact's impulse and the velocities of its bodies. A cluster enters the statistics
// only if the body i of its first contact is below `counted_below` (on several ranks: the
// owned bodies, so that every cluster is counted by exactly one rank).
ResolutionStats resolve_clusters(Particles &p, const Shape &shape, std::vector<Contact> &contacts,
                                 const ContactClusters &clusters, const std::vector<char> &active,
                                 const SolverSettings &settings,
                                 std::size_t counted_below = static_cast<std::size_t>(-1));

// Convenience for one rank: find and resolve every cluster.
ResolutionStats resolve_contacts(Particles &p, const Shape &shape, std::vector<Contact> &contacts,
                                 const SolverSettings &settings);

// Collision virial over contacts with counted[k] != 0 (all when `counted` is empty):
// the sum of J n . (x_i - x_j), and how many of them received an impulse.
struct CollisionTally {
  ExactSum virial;
  long long collisions = 0;
};
CollisionTally tally_collisions(const std::vector<Contact> &contacts,
                                const std::vector<char> &counted);

// Relative normal velocity u = n . ((v_i + w_i x r_i) - (v_j + w_j x r_j)).
double normal_velocity(const Particles &p, const Contact &c);

}  // namespace hardrod
