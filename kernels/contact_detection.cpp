#include "kernels/contact_detection.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>

#include "kernels/segment_geometry.hpp"

namespace hardrod {

bool make_contact(const Particles &p, const Box &box, const Vec3 &inverse, const Shape &shape,
                  std::uint32_t a, std::uint32_t b, Contact &c, double &distance) {
  // Canonical orientation by global id: the same arithmetic on every rank.
  const std::uint32_t i = p.id[a] < p.id[b] ? a : b;
  const std::uint32_t j = p.id[a] < p.id[b] ? b : a;
  const double h = shape.half_length();
  const Vec3 rij = box.minimum_image(p.position(j) - p.position(i), inverse);
  const Vec3 ei = p.axis(i), ej = p.axis(j);
  const SegmentClosest sc = segment_closest(rij, ei, h, ej, h);
  distance = std::sqrt(sc.dist2);
  if (!(distance < shape.diameter)) return false;
  c.i = i;
  c.j = j;
  c.id_i = p.id[i];
  c.id_j = p.id[j];
  c.normal = contact_normal(sc, rij, ei, ej);
  c.separation = -rij;
  c.depth = shape.diameter - distance;
  c.arm_i = sc.s * cross(ei, c.normal);
  c.arm_j = sc.t * cross(ej, c.normal);
  const double inv_m = 1.0 / shape.mass;
  const double inv_i = shape.inverse_inertia();
  c.inverse_mass = 2.0 * inv_m + inv_i * (norm2(c.arm_i) + norm2(c.arm_j));
  c.impulse = 0.0;
  return true;
}

DetectionStats detect_contacts(const Particles &p, const Box &box, const Shape &shape,
                               NeighborList &list, std::vector<Contact> &contacts) {
  const int nthreads = omp_get_max_threads();
  std::vector<std::vector<Contact>> found(nthreads);
  long long tests = 0;
  double max_depth = 0.0;
  const std::size_t npairs = list.pair_count();
  const std::uint32_t *first = list.first.data();
  const std::uint32_t *second = list.second.data();
  double *recheck_at = list.recheck_at.data();
  const double *bound = p.motion_bound.data();
  const Vec3 inverse = box.inverse_length();

  // Threaded exactly when the integration is (kParallelBodies, particles.hpp).
  const bool threaded = static_cast<long>(list.active) > kParallelBodies;
#pragma omp parallel reduction(+ : tests) reduction(max : max_depth) if (threaded)
  {
    auto &mine = found[omp_get_thread_num()];
#pragma omp for schedule(static)
    for (std::size_t k = 0; k < npairs; ++k) {
      const double moved = bound[first[k]] + bound[second[k]];
      if (moved < recheck_at[k]) continue;  // cannot have closed its gap yet
      ++tests;
      Contact c;
      double d = 0.0;
      if (make_contact(p, box, inverse, shape, first[k], second[k], c, d)) {
        max_depth = std::max(max_depth, c.depth);
        mine.push_back(c);
      }
      recheck_at[k] = moved + (d - shape.diameter) - kDistanceSafetyMargin;
    }
  }

  contacts.clear();
  for (auto &f : found) contacts.insert(contacts.end(), f.begin(), f.end());
  std::sort(contacts.begin(), contacts.end(), canonical_less);
  return {tests, max_depth};
}

}  // namespace hardrod
