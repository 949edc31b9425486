#include "kernels/neighbor_list.hpp"

#include <omp.h>

#include <algorithm>

#include "kernels/segment_geometry.hpp"

namespace hardrod {

void build_neighbor_list(NeighborList &list, Particles &p, std::size_t count, const Box &box,
                         const Shape &shape) {
  const double reach = shape.diameter + list.skin;  // segment distance kept in the list
  const double centre_reach = shape.length + reach;
  const double centre_reach2 = centre_reach * centre_reach;
  const double h = shape.half_length();
  build_cell_list(list.cells, p, count, box, centre_reach);
  const CellList &cl = list.cells;

  const int nthreads = omp_get_max_threads();
  std::vector<std::vector<std::uint32_t>> first(nthreads), second(nthreads);
  std::vector<std::vector<double>> recheck(nthreads);

#pragma omp parallel
  {
    const int tid = omp_get_thread_num();
    auto &f = first[tid];
    auto &s = second[tid];
    auto &r = recheck[tid];
#pragma omp for schedule(dynamic, 8)
    for (int c = 0; c < cl.cell_count(); ++c) {
      const int cx = c % cl.cells[0];
      const int cy = (c / cl.cells[0]) % cl.cells[1];
      const int cz = c / (cl.cells[0] * cl.cells[1]);
      for (std::uint32_t a = cl.cell_start[c]; a < cl.cell_start[c + 1]; ++a) {
        const std::uint32_t i = cl.order[a];
        const Vec3 xi = p.position(i);
        const Vec3 ei = p.axis(i);
        for (const auto &o : cl.stencil) {
          const int nc = cl.neighbour(cx, cy, cz, o);
          for (std::uint32_t b = cl.cell_start[nc]; b < cl.cell_start[nc + 1]; ++b) {
            const std::uint32_t j = cl.order[b];
            if (j <= i) continue;  // each unordered pair once
            const Vec3 rij = box.minimum_image(p.position(j) - xi);
            if (norm2(rij) >= centre_reach2) continue;
            const SegmentClosest sc = segment_closest(rij, ei, h, p.axis(j), h);
            const double d = std::sqrt(sc.dist2);
            if (d >= reach) continue;
            f.push_back(i);
            s.push_back(j);
            r.push_back(d - shape.diameter - kDistanceSafetyMargin);
          }
        }
      }
    }
  }

  list.first.clear();
  list.second.clear();
  list.recheck_at.clear();
  for (int t = 0; t < nthreads; ++t) {
    list.first.insert(list.first.end(), first[t].begin(), first[t].end());
    list.second.insert(list.second.end(), second[t].begin(), second[t].end());
    list.recheck_at.insert(list.recheck_at.end(), recheck[t].begin(), recheck[t].end());
  }
  std::fill(p.motion_bound.begin(), p.motion_bound.begin() + static_cast<long>(count), 0.0);
  list.bodies = count;
  ++list.builds;
}

bool neighbor_list_expired(const NeighborList &list, const Particles &p, std::size_t count) {
  if (list.builds == 0 || list.bodies != count) return true;
  double largest = 0.0, second = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    const double m = p.motion_bound[i];
    if (m > largest) {
      second = largest;
      largest = m;
    } else if (m > second) {
      second = m;
    }
  }
  return largest + second >= list.skin - kDistanceSafetyMargin;
}

}  // namespace hardrod
