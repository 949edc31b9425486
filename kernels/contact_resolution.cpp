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

ResolutionStats resolve_clusters(Particles &p, const Shape &shape, std::vector<Contact> &contacts,
                                 const ContactClusters &cc, const std::vector<char> &active,
                                 const SolverSettings &settings, std::size_t counted_below) {
  ResolutionStats stats;
  const double inv_m = 1.0 / shape.mass;
  const double inv_i = shape.inverse_inertia();
  const double inertia = shape.is_sphere() ? 0.0 : shape.inertia_perp();
  const long ncl = static_cast<long>(cc.count());
  const std::vector<std::uint32_t> &by_cluster = cc.order;
  const std::vector<std::size_t> &cluster_start = cc.start;
  for (Contact &c : contacts) c.approach_velocity = normal_velocity(p, c);

  const int nthreads = omp_get_max_threads();
  std::vector<ExactSum> energy(nthreads);
  long long clusters = 0, iterations_max = 0, unconverged = 0;

  // A handful of clusters (the common case at small dt) is resolved on the calling thread.
#pragma omp parallel reduction(+ : clusters, unconverged) reduction(max : iterations_max) if (ncl > 32)
  {
    ExactSum &my_energy = energy[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 16)
    for (long cl = 0; cl < ncl; ++cl) {
      if (!active.empty() && !active[cl]) continue;
      const std::size_t begin = cluster_start[cl], end = cluster_start[cl + 1];
      if (end - begin == 1) {  // isolated contact: the exact elastic impulse
        Contact &c = contacts[by_cluster[begin]];
        const double lambda = std::max(
            0.0, (target_velocity(c.approach_velocity) - c.approach_velocity) / c.inverse_mass);
        c.impulse = lambda;
        if (lambda > 0.0) apply_impulse(p, c, lambda, inv_m, inv_i);
        continue;
      }
      const bool counted = contacts[by_cluster[begin]].i < counted_below;
      if (counted) ++clusters;
      std::vector<std::uint32_t> members;
      double scale = 0.0;
      for (std::size_t k = begin; k < end; ++k) {
        const Contact &c = contacts[by_cluster[k]];
        members.push_back(c.i);
        members.push_back(c.j);
        scale = std::max(scale, std::fabs(c.approach_velocity));
      }
      // In id order, so that the energy sums below round the same way on every rank.
      std::sort(members.begin(), members.end(),
                [&p](std::uint32_t a, std::uint32_t b) { return p.id[a] < p.id[b]; });
      members.erase(std::unique(members.begin(), members.end()), members.end());
      double energy_before = 0.0;
      if (counted)
        for (std::uint32_t b : members)
          energy_before += kinetic_energy_of(p, b, shape.mass, inertia);
      const double tolerance = settings.tolerance * std::max(scale, 1e-300);
      long long it = 0;
      for (; it < settings.max_iterations; ++it) {
        double residual = 0.0;
        for (std::size_t k = begin; k < end; ++k) {
          Contact &c = contacts[by_cluster[k]];
          const double u = normal_velocity(p, c);
          const double wanted =
              c.impulse + (target_velocity(c.approach_velocity) - u) / c.inverse_mass;
          const double lambda = std::max(0.0, wanted);
          const double delta = lambda - c.impulse;
          if (delta != 0.0) apply_impulse(p, c, delta, inv_m, inv_i);
          c.impulse = lambda;
          residual = std::max(residual, std::fabs(delta) * c.inverse_mass);
        }
        if (residual <= tolerance) break;
      }
      if (!counted) continue;
      iterations_max = std::max(iterations_max, it + 1);
      if (it == settings.max_iterations) ++unconverged;
      double energy_after = 0.0;
      for (std::uint32_t b : members) energy_after += kinetic_energy_of(p, b, shape.mass, inertia);
      my_energy.add(energy_after - energy_before);
    }
  }
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
