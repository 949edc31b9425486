#include "kernels/contact_resolution.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "kernels/union_find.hpp"

namespace hardrod {

namespace {

void apply_impulse(Particles &p, const Contact &c, double lambda, double inv_m, double inv_i) {
  const double a = lambda * inv_m;
  p.vx[c.i] += a * c.normal.x;
  p.vy[c.i] += a * c.normal.y;
  p.vz[c.i] += a * c.normal.z;
  p.vx[c.j] -= a * c.normal.x;
  p.vy[c.j] -= a * c.normal.y;
  p.vz[c.j] -= a * c.normal.z;
  const double b = lambda * inv_i;
  p.wx[c.i] += b * c.arm_i.x;
  p.wy[c.i] += b * c.arm_i.y;
  p.wz[c.i] += b * c.arm_i.z;
  p.wx[c.j] -= b * c.arm_j.x;
  p.wy[c.j] -= b * c.arm_j.y;
  p.wz[c.j] -= b * c.arm_j.z;
}

double target_velocity(double u0) { return u0 < 0.0 ? -u0 : 0.0; }

double kinetic_energy_of(const Particles &p, std::uint32_t b, double mass, double inertia) {
  return 0.5 * mass * norm2(p.velocity(b)) + 0.5 * inertia * norm2(p.angular_velocity(b));
}

// Disjoint-set forest over the compact body indices of this step's contacts.
struct Clusters {
  std::vector<std::uint32_t> parent;
  std::uint32_t root(std::uint32_t a) { return set_root(parent, a); }
  void join(std::uint32_t a, std::uint32_t b) { join_sets(parent, a, b); }
};

}  // namespace

double normal_velocity(const Particles &p, const Contact &c) {
  return dot(c.normal, p.velocity(c.i) - p.velocity(c.j)) + dot(p.angular_velocity(c.i), c.arm_i) -
         dot(p.angular_velocity(c.j), c.arm_j);
}

std::size_t ContactClusters::find(std::uint32_t b) const {
  const auto it = std::lower_bound(bodies.begin(), bodies.end(), b);
  return (it != bodies.end() && *it == b) ? static_cast<std::size_t>(it - bodies.begin())
                                          : bodies.size();
}

ContactClusters find_clusters(const std::vector<Contact> &contacts) {
  ContactClusters cc;
  const std::size_t nc = contacts.size();
  if (nc == 0) return cc;
  for (const Contact &c : contacts) {
    cc.bodies.push_back(c.i);
    cc.bodies.push_back(c.j);
  }
  std::sort(cc.bodies.begin(), cc.bodies.end());
  cc.bodies.erase(std::unique(cc.bodies.begin(), cc.bodies.end()), cc.bodies.end());
  cc.degree.assign(cc.bodies.size(), 0);
  Clusters forest;
  forest.parent.resize(cc.bodies.size());
  std::iota(forest.parent.begin(), forest.parent.end(), 0u);
  std::vector<std::uint32_t> root_of(nc);
  for (const Contact &c : contacts) {
    const auto a = static_cast<std::uint32_t>(cc.find(c.i));
    const auto b = static_cast<std::uint32_t>(cc.find(c.j));
    ++cc.degree[a];
    ++cc.degree[b];
    forest.join(a, b);
  }
  for (std::uint32_t d : cc.degree)
    if (d > 1) ++cc.multi_contact_bodies;
  for (std::size_t k = 0; k < nc; ++k)
    root_of[k] = forest.root(static_cast<std::uint32_t>(cc.find(contacts[k].i)));
  // Contacts grouped by cluster; within a cluster they keep their canonical order.
  cc.order.resize(nc);
  std::iota(cc.order.begin(), cc.order.end(), 0u);
  std::stable_sort(cc.order.begin(), cc.order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return root_of[a] < root_of[b]; });
  for (std::size_t k = 0; k < nc; ++k)
    if (k == 0 || root_of[cc.order[k]] != root_of[cc.order[k - 1]]) cc.start.push_back(k);
  cc.start.push_back(nc);
  return cc;
}

namespace {

// What every cluster's solve reads.
struct Solve {
  Particles &p;
  std::vector<Contact> &contacts;
  const std::vector<std::uint32_t> &order;  // contacts by cluster (ContactClusters::order)
  double inv_m, inv_i, mass, inertia;
  const SolverSettings &settings;
};

// A contact alone in its cluster: the exact elastic impulse.
void resolve_isolated(const Solve &s, Contact &c) {
  const double lambda =
      std::max(0.0, (target_velocity(c.approach_velocity) - c.approach_velocity) / c.inverse_mass);
  c.impulse = lambda;
  if (lambda > 0.0) apply_impulse(s.p, c, lambda, s.inv_m, s.inv_i);
}

// The bodies of contacts order[begin, end), in id order (so that the energy sums round the same
// way on every rank), and the largest approach speed among those contacts (`scale`).
std::vector<std::uint32_t> members_of(const Solve &s, std::size_t begin, std::size_t end,
                                      double &scale) {
  std::vector<std::uint32_t> members;
  scale = 0.0;
  for (std::size_t k = begin; k < end; ++k) {
    const Contact &c = s.contacts[s.order[k]];
    members.push_back(c.i);
    members.push_back(c.j);
    scale = std::max(scale, std::fabs(c.approach_velocity));
  }
  const Particles &p = s.p;
  std::sort(members.begin(), members.end(),
            [&p](std::uint32_t a, std::uint32_t b) { return p.id[a] < p.id[b]; });
  members.erase(std::unique(members.begin(), members.end()), members.end());
  return members;
}

double energy_of_members(const Solve &s, const std::vector<std::uint32_t> &members) {
  double sum = 0.0;
  for (std::uint32_t b : members) sum += kinetic_energy_of(s.p, b, s.mass, s.inertia);
  return sum;
}

// Projected Gauss-Seidel sweeps over contacts order[begin, end) until no impulse changes by more
// than `tolerance` (as a velocity). Returns the sweeps before the last (max_iterations when it
// did not converge).
long long sweep_cluster(const Solve &s, std::size_t begin, std::size_t end, double tolerance) {
  long long it = 0;
  for (; it < s.settings.max_iterations; ++it) {
    double residual = 0.0;
    for (std::size_t k = begin; k < end; ++k) {
      Contact &c = s.contacts[s.order[k]];
      const double u = normal_velocity(s.p, c);
      const double wanted = c.impulse + (target_velocity(c.approach_velocity) - u) / c.inverse_mass;
      const double lambda = std::max(0.0, wanted);
      const double delta = lambda - c.impulse;
      if (delta != 0.0) apply_impulse(s.p, c, delta, s.inv_m, s.inv_i);
      c.impulse = lambda;
      residual = std::max(residual, std::fabs(delta) * c.inverse_mass);
    }
    if (residual <= tolerance) break;
  }
  return it;
}

}  // namespace

ResolutionStats resolve_clusters(Particles &p, const Shape &shape, std::vector<Contact> &contacts,
                                 const ContactClusters &cc, const std::vector<char> &active,
                                 const SolverSettings &settings, std::size_t counted_below) {
  const Solve s{p,
                contacts,
                cc.order,
                1.0 / shape.mass,
                shape.inverse_inertia(),
                shape.mass,
                shape.is_sphere() ? 0.0 : shape.inertia_perp(),
                settings};
  const long ncl = static_cast<long>(cc.count());
  for (Contact &c : contacts) c.approach_velocity = normal_velocity(p, c);

  std::vector<ExactSum> energy(omp_get_max_threads());
  long long clusters = 0, iterations_max = 0, unconverged = 0;
  // A handful of clusters (the common case at small dt) is resolved on the calling thread.
#pragma omp parallel reduction(+ : clusters, unconverged) reduction(max : iterations_max) if (ncl > 32)
  {
    ExactSum &my_energy = energy[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 16)
    for (long cl = 0; cl < ncl; ++cl) {
      if (!active.empty() && !active[cl]) continue;
      const std::size_t begin = cc.start[cl], end = cc.start[cl + 1];
      if (end - begin == 1) {
        resolve_isolated(s, contacts[cc.order[begin]]);
        continue;
      }
      const bool counted = contacts[cc.order[begin]].i < counted_below;
      clusters += counted;
      double scale = 0.0;
      const std::vector<std::uint32_t> members = members_of(s, begin, end, scale);
      const double energy_before = counted ? energy_of_members(s, members) : 0.0;
      const long long it =
          sweep_cluster(s, begin, end, settings.tolerance * std::max(scale, 1e-300));
      if (!counted) continue;
      iterations_max = std::max(iterations_max, it + 1);
      if (it == settings.max_iterations) ++unconverged;
      my_energy.add(energy_of_members(s, members) - energy_before);
    }
  }
  ResolutionStats stats;
  stats.clusters = clusters;
  stats.iterations_max = iterations_max;
  stats.unconverged = unconverged;
  ExactSum energy_change;
  for (const ExactSum &e : energy) energy_change += e;
  stats.energy_change = energy_change.value();
  return stats;
}

ResolutionStats resolve_contacts(Particles &p, const Shape &shape, std::vector<Contact> &contacts,
                                 const SolverSettings &settings) {
  return resolve_clusters(p, shape, contacts, find_clusters(contacts), {}, settings);
}

CollisionTally tally_collisions(const std::vector<Contact> &contacts,
                                const std::vector<char> &counted) {
  CollisionTally t;
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const Contact &c = contacts[k];
    if ((!counted.empty() && !counted[k]) || !(c.impulse > 0.0)) continue;
    ++t.collisions;
    t.virial.add(c.impulse * dot(c.normal, c.separation));
  }
  return t;
}

}  // namespace hardrod
