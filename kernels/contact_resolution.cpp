#include "kernels/contact_resolution.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>

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
  std::uint32_t root(std::uint32_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  }
  void join(std::uint32_t a, std::uint32_t b) {
    a = root(a);
    b = root(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

}  // namespace

double normal_velocity(const Particles &p, const Contact &c) {
  return dot(c.normal, p.velocity(c.i) - p.velocity(c.j)) + dot(p.angular_velocity(c.i), c.arm_i) -
         dot(p.angular_velocity(c.j), c.arm_j);
}

ResolutionStats resolve_contacts(Particles &p, const Shape &shape, std::vector<Contact> &contacts,
                                 const SolverSettings &settings) {
  ResolutionStats stats;
  const std::size_t nc = contacts.size();
  if (nc == 0) return stats;
  const double inv_m = 1.0 / shape.mass;
  const double inv_i = shape.inverse_inertia();
  const double inertia = shape.is_sphere() ? 0.0 : shape.inertia_perp();

  // Compact body numbering, then clusters of contacts that share a body.
  std::vector<std::uint32_t> bodies;
  bodies.reserve(2 * nc);
  for (const Contact &c : contacts) {
    bodies.push_back(c.i);
    bodies.push_back(c.j);
  }
  std::sort(bodies.begin(), bodies.end());
  std::vector<std::uint32_t> touches(bodies.size());  // contacts per compact body
  auto compact = [&](std::uint32_t b) {
    return static_cast<std::uint32_t>(std::lower_bound(bodies.begin(), bodies.end(), b) -
                                      bodies.begin());
  };
  Clusters forest;
  forest.parent.resize(bodies.size());
  std::iota(forest.parent.begin(), forest.parent.end(), 0u);
  for (const Contact &c : contacts) forest.join(compact(c.i), compact(c.j));
  for (std::uint32_t b : bodies) ++touches[compact(b)];
  for (std::size_t k = 0; k < bodies.size(); ++k)
    if (touches[k] > 1 && (k == 0 || bodies[k] != bodies[k - 1])) ++stats.multi_contact_bodies;

  // Contacts grouped by cluster; clusters ordered by their first (canonical) contact.
  std::vector<std::uint32_t> cluster_of(nc);
  for (std::size_t k = 0; k < nc; ++k) cluster_of[k] = forest.root(compact(contacts[k].i));
  std::vector<std::uint32_t> by_cluster(nc);
  std::iota(by_cluster.begin(), by_cluster.end(), 0u);
  std::stable_sort(by_cluster.begin(), by_cluster.end(), [&](std::uint32_t a, std::uint32_t b) {
    return cluster_of[a] < cluster_of[b];
  });
  std::vector<std::size_t> cluster_start;
  for (std::size_t k = 0; k < nc; ++k)
    if (k == 0 || cluster_of[by_cluster[k]] != cluster_of[by_cluster[k - 1]])
      cluster_start.push_back(k);
  cluster_start.push_back(nc);
  const long ncl = static_cast<long>(cluster_start.size()) - 1;

  for (Contact &c : contacts) c.approach_velocity = normal_velocity(p, c);

  const int nthreads = omp_get_max_threads();
  std::vector<ExactSum> virial(nthreads), energy(nthreads);
  long long collisions = 0, clusters = 0, iterations_max = 0, unconverged = 0;

  // A handful of clusters (the common case at small dt) is resolved on the calling thread.
#pragma omp parallel reduction(+ : collisions, clusters, unconverged) \
    reduction(max : iterations_max) if (ncl > 32)
  {
    ExactSum &my_virial = virial[omp_get_thread_num()];
    ExactSum &my_energy = energy[omp_get_thread_num()];
#pragma omp for schedule(dynamic, 16)
    for (long cl = 0; cl < ncl; ++cl) {
      const std::size_t begin = cluster_start[cl], end = cluster_start[cl + 1];
      if (end - begin == 1) {  // isolated contact: the exact elastic impulse
        Contact &c = contacts[by_cluster[begin]];
        const double lambda =
            std::max(0.0, (target_velocity(c.approach_velocity) - c.approach_velocity) /
                              c.inverse_mass);
        c.impulse = lambda;
        if (lambda > 0.0) apply_impulse(p, c, lambda, inv_m, inv_i);
      } else {
        ++clusters;
        std::vector<std::uint32_t> members;
        double scale = 0.0;
        for (std::size_t k = begin; k < end; ++k) {
          const Contact &c = contacts[by_cluster[k]];
          members.push_back(c.i);
          members.push_back(c.j);
          scale = std::max(scale, std::fabs(c.approach_velocity));
        }
        std::sort(members.begin(), members.end());
        members.erase(std::unique(members.begin(), members.end()), members.end());
        double energy_before = 0.0;
        for (std::uint32_t b : members) energy_before += kinetic_energy_of(p, b, shape.mass, inertia);
        const double tolerance = settings.tolerance * std::max(scale, 1e-300);
        long long it = 0;
        for (; it < settings.max_iterations; ++it) {
          double residual = 0.0;
          for (std::size_t k = begin; k < end; ++k) {
            Contact &c = contacts[by_cluster[k]];
            const double u = normal_velocity(p, c);
            const double wanted = c.impulse + (target_velocity(c.approach_velocity) - u) /
                                                  c.inverse_mass;
            const double lambda = std::max(0.0, wanted);
            const double delta = lambda - c.impulse;
            if (delta != 0.0) apply_impulse(p, c, delta, inv_m, inv_i);
            c.impulse = lambda;
            residual = std::max(residual, std::fabs(delta) * c.inverse_mass);
          }
          if (residual <= tolerance) break;
        }
        iterations_max = std::max(iterations_max, it + 1);
        if (it == settings.max_iterations) ++unconverged;
        double energy_after = 0.0;
        for (std::uint32_t b : members) energy_after += kinetic_energy_of(p, b, shape.mass, inertia);
        my_energy.add(energy_after - energy_before);
      }
      for (std::size_t k = begin; k < end; ++k) {
        const Contact &c = contacts[by_cluster[k]];
        if (c.impulse > 0.0) {
          ++collisions;
          my_virial.add(c.impulse * dot(c.normal, c.separation));
        }
      }
    }
  }
  stats.collisions = collisions;
  stats.clusters = clusters;
  stats.iterations_max = iterations_max;
  stats.unconverged = unconverged;
  ExactSum energy_change;
  for (int t = 0; t < nthreads; ++t) {
    stats.virial += virial[t];
    energy_change += energy[t];
  }
  stats.energy_change = energy_change.value();
  return stats;
}

}  // namespace hardrod
