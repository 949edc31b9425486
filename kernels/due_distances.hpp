// The distances of a batch of due pairs (kernels/pair_scan.hpp), as make_contact measures them
// (canonical orientation by id, minimum image, segment_closest_inline's arithmetic; spheres:
// the centres' distance), in one loop without branches that runs in vector lanes with the same
// operations and so the same bits (no contraction: -ffp-contract=off). What the methods' measures
// share: the midpoint method's contacts (contact_detection.cpp) and the exact method's
// candidates (kernels/exact/step_candidates.cpp). One thread per batch.
#pragma once

#include <cstddef>
#include <cstdint>

#include "kernels/box.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/particles.hpp"
#include "kernels/segment_geometry.hpp"

namespace hardrod {

// A batch of due pairs measured: bodies i and j in canonical orientation (id[i] < id[j]), j's
// centre from i's (minimum image), and their closest points (rods).
inline constexpr std::size_t kDueBatch = 256;
struct DueBatch {
  std::uint32_t i[kDueBatch], j[kDueBatch];
  double rx[kDueBatch], ry[kDueBatch], rz[kDueBatch];
  double s[kDueBatch], t[kDueBatch], gx[kDueBatch], gy[kDueBatch], gz[kDueBatch];
  double dist2[kDueBatch], distance[kDueBatch];

  Vec3 r(std::size_t q) const { return {rx[q], ry[q], rz[q]}; }
  SegmentClosest closest(std::size_t q) const {
    return {s[q], t[q], {gx[q], gy[q], gz[q]}, dist2[q]};
  }
};

// The due pairs pairs[due[0, n)] measured into `out`.
template <bool Rods>
inline void due_distances(const Particles &p, const Box &box, const Vec3 &inverse, double h,
                          const ListedPair *__restrict pairs, const std::uint32_t *__restrict due,
                          std::size_t n, DueBatch &__restrict out) {
  const std::int64_t *__restrict id = p.id.data();
  const double *__restrict x = p.x.data(), *__restrict y = p.y.data(), *__restrict z = p.z.data();
  const double *__restrict ex = p.ex.data(), *__restrict ey = p.ey.data(),
                           *__restrict ez = p.ez.data();
  const Box image = box;
#pragma omp simd
  for (std::size_t q = 0; q < n; ++q) {
    const std::uint32_t a = pairs[due[q]].first, b = pairs[due[q]].second;
    const bool swap = id[b] < id[a];  // canonical orientation
    const std::uint32_t i = swap ? b : a, j = swap ? a : b;
    const Vec3 rij = image.minimum_image({x[j] - x[i], y[j] - y[i], z[j] - z[i]}, inverse);
    out.i[q] = i;
    out.j[q] = j;
    out.rx[q] = rij.x;
    out.ry[q] = rij.y;
    out.rz[q] = rij.z;
    if constexpr (Rods) {
      const SegmentClosest sc =
          segment_closest_inline(rij, {ex[i], ey[i], ez[i]}, h, {ex[j], ey[j], ez[j]}, h);
      out.s[q] = sc.s;
      out.t[q] = sc.t;
      out.gx[q] = sc.gap.x;
      out.gy[q] = sc.gap.y;
      out.gz[q] = sc.gap.z;
      out.dist2[q] = sc.dist2;
      out.distance[q] = std::sqrt(sc.dist2);
    } else {
      out.distance[q] = std::sqrt(norm2(rij));
    }
  }
}

// A contact's (or candidate's) bodies and ids, i first (the canonical orientation).
template <class C>
inline void name_bodies(const Particles &p, std::uint32_t i, std::uint32_t j, C &c) {
  c.i = i;
  c.j = j;
  c.id_i = p.id[i];
  c.id_j = p.id[j];
}

// due_distances for the shape: rods, or spheres (h = 0).
inline void measure_distances(const Particles &p, const Box &box, const Vec3 &inverse, double h,
                              const ListedPair *pairs, const std::uint32_t *due, std::size_t n,
                              DueBatch &out) {
  if (h == 0.0)
    due_distances<false>(p, box, inverse, h, pairs, due, n, out);
  else
    due_distances<true>(p, box, inverse, h, pairs, due, n, out);
}

}  // namespace hardrod
