// The order of the pair list (kernels/neighbor_list.cpp), pair by pair and bit for bit: cell by
// cell, each body of the cell against the later bodies of its cell, then against the bodies of
// the stencil's later cells, in stencil order; each pair whose segments are closer than
// D + skin listed with its slack. The steps visit the pairs in this order and the trajectory
// depends on it, so the search may walk the stencil however it likes (axis by axis, merging
// neighbouring cells) as long as it lists exactly this. The reference here walks
// CellList::stencil one offset at a time through CellList::neighbour and measures every
// candidate exactly. Two cells per reach (the 125-cell stencil), the reduced stencil of a small
// box, a fitted window with empty cells around it, a window across the periodic boundary,
// spheres, and two threads.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "kernels/neighbor_list.hpp"
#include "kernels/segment_geometry.hpp"

namespace hardrod {
namespace {

struct Case {
  std::string name;
  double length, skin;
  double scale;      // box side in units of the reach, per axis roughly
  double low, high;  // centres within [low, high) of the box along x (may wrap below 0)
  bool aligned;
  int threads;
  std::size_t stencil;  // the stencil the case must take
  bool full_stencil;
};

Particles bodies(const Case &c, const Box &box, std::size_t n) {
  std::mt19937_64 rng(29);
  std::uniform_real_distribution<double> u(0.0, 1.0), ux(c.low, c.high);
  std::normal_distribution<double> g(0.0, 1.0);
  Particles p;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(n - i);
    p.set_position(i, {ux(rng) * box.length.x, u(rng) * box.length.y, u(rng) * box.length.z});
    const Vec3 e = c.aligned ? Vec3{1.0, 0.2 * g(rng), 0.2 * g(rng)} : Vec3{g(rng), g(rng), g(rng)};
    p.set_axis(i, (1.0 / norm(e)) * e);
  }
  return p;
}

// The list as the stencil walk defines it, from the bodies and cells the build left.
std::vector<ListedPair> reference(const NeighborList &list, const Particles &p, const Box &box,
                                  const Shape &shape) {
  const CellList &cl = list.cells;
  const double reach = shape.diameter + list.skin, h = shape.half_length();
  std::vector<ListedPair> out;
  for (int c = 0; c < cl.cell_count(); ++c) {
    const int cx = c % cl.extent[0], cy = (c / cl.extent[0]) % cl.extent[1],
              cz = c / (cl.extent[0] * cl.extent[1]);
    std::vector<std::uint32_t> cand(cl.order.begin() + cl.cell_start[c],
                                    cl.order.begin() + cl.cell_start[c + 1]);
    const std::size_t own = cand.size();
    for (const auto &o : cl.stencil) {
      const int nc = cl.neighbour(cx, cy, cz, o);
      if (nc <= c) continue;
      cand.insert(cand.end(), cl.order.begin() + cl.cell_start[nc],
                  cl.order.begin() + cl.cell_start[nc + 1]);
    }
    for (std::size_t a = 0; a < own; ++a)
      for (std::size_t q = a + 1; q < cand.size(); ++q) {
        const std::uint32_t i = cand[a], j = cand[q];
        const Vec3 r = box.minimum_image(p.position(j) - p.position(i));
        const double d = std::sqrt(segment_closest(r, p.axis(i), h, p.axis(j), h).dist2);
        if (d < reach)
          out.push_back({i, j, slack_below(d - shape.diameter - kDistanceSafetyMargin), 0.0f});
      }
  }
  return out;
}

class ListOrder : public ::testing::TestWithParam<Case> {};

TEST_P(ListOrder, IsTheStencilWalksPairByPair) {
  const Case c = GetParam();
  Shape shape;
  shape.length = c.length;
  const double range = c.length + shape.diameter + c.skin;
  Box box;
  box.length = {c.scale * range + 1.0, c.scale * range * 0.9 + 2.0, c.scale * range * 0.95 + 1.5};
  // 0.4 of the volume filled where the bodies are (dense enough for two cells per reach).
  const double filled = (c.high - c.low) * box.volume();
  const auto n = static_cast<std::size_t>(0.4 * filled / shape.volume());
  Particles p = bodies(c, box, n);
  NeighborList list;
  list.skin = c.skin;
  omp_set_num_threads(c.threads);
  build_neighbor_list(list, p, n, box, shape);
  omp_set_num_threads(1);
  EXPECT_EQ(list.cells.stencil.size(), c.stencil) << "the case must take the stencil it names";
  EXPECT_EQ(list.cells.full_stencil, c.full_stencil);
  if (c.high - c.low < 1.0) {
    EXPECT_LT(list.cells.extent[0], list.cells.cells[0]) << "the case must have a window";
  }

  const std::vector<ListedPair> expected = reference(list, p, box, shape);
  ASSERT_EQ(list.pair_count(), expected.size());
  EXPECT_GT(expected.size(), n) << "the test must list pairs";
  for (std::size_t k = 0; k < expected.size(); ++k) {
    const ListedPair &got = list.pairs[k], &want = expected[k];
    ASSERT_EQ(got.first, want.first) << "pair " << k;
    ASSERT_EQ(got.second, want.second) << "pair " << k;
    ASSERT_EQ(got.recheck_at, want.recheck_at) << "pair " << k;  // bit for bit
  }
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, ListOrder,
    ::testing::Values(
        Case{"rods_two_cells_per_reach", 5.0, 0.3, 3.1, 0.0, 1.0, true, 1, 125, true},
        Case{"rods_two_threads", 5.0, 0.3, 3.1, 0.0, 1.0, true, 2, 125, true},
        Case{"rods_small_box", 5.0, 0.8, 2.1, 0.0, 1.0, false, 1, 8, false},
        Case{"rods_corner_of_a_wide_box", 5.0, 0.3, 12.0, 0.0, 0.25, true, 1, 125, true},
        Case{"rods_across_the_boundary", 5.0, 0.3, 12.0, -0.15, 0.15, true, 1, 125, true},
        Case{"spheres", 0.0, 0.3, 8.0, 0.0, 1.0, false, 1, 27, true}),
    [](const ::testing::TestParamInfo<Case> &info) { return info.param.name; });

}  // namespace
}  // namespace hardrod
