// The linked-cell broad phase (kernels/cell_list.hpp) against brute force: walked as the
// neighbour list walks it (each cell's stencil, later cells only), every pair of centres
// closer than the reach is met exactly once and no pair twice, with and without the fitted
// window, in large boxes (two cells per reach), boxes of one, two or three cells per axis
// (the reduced stencil), gases with empty cells, clusters, and centres outside the box.
// Also: the binning itself (order is a permutation, each body in the cell of its centre), and
// the stencil as the product of its per-axis offsets.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "kernels/cell_list.hpp"

namespace hardrod {
namespace {

using Pair = std::pair<std::uint32_t, std::uint32_t>;

// Bodies with centres uniform in [low, high) per axis (fractions of the box; may lie outside
// [0, 1) to give unfolded centres).
Particles centres(std::size_t n, const Box &box, std::uint64_t seed, double low = 0.0,
                  double high = 1.0) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(low, high);
  Particles p;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(i);
    p.set_position(i, {u(rng) * box.length.x, u(rng) * box.length.y, u(rng) * box.length.z});
    p.set_axis(i, {1.0, 0.0, 0.0});
  }
  return p;
}

std::set<Pair> brute_force(const Particles &p, const Box &box, double reach) {
  std::set<Pair> out;
  for (std::uint32_t i = 0; i < p.size(); ++i)
    for (std::uint32_t j = i + 1; j < p.size(); ++j)
      if (norm(box.minimum_image(p.position(j) - p.position(i))) < reach) out.insert({i, j});
  return out;
}

// Every pair the list offers, counted: from each cell, its own later bodies and the bodies of
// the stencil's cells with a higher index (as build_neighbor_list walks it).
std::map<Pair, int> walk(const CellList &cl) {
  std::map<Pair, int> met;
  auto meet = [&](std::uint32_t a, std::uint32_t b) { ++met[{std::min(a, b), std::max(a, b)}]; };
  for (int c = 0; c < cl.cell_count(); ++c) {
    const int cx = c % cl.extent[0], cy = (c / cl.extent[0]) % cl.extent[1],
              cz = c / (cl.extent[0] * cl.extent[1]);
    for (std::uint32_t a = cl.cell_start[c]; a < cl.cell_start[c + 1]; ++a) {
      for (std::uint32_t b = a + 1; b < cl.cell_start[c + 1]; ++b) meet(cl.order[a], cl.order[b]);
      for (const auto &o : cl.stencil) {
        const int nc = cl.neighbour(cx, cy, cz, o);
        if (nc <= c) continue;
        for (std::uint32_t b = cl.cell_start[nc]; b < cl.cell_start[nc + 1]; ++b)
          meet(cl.order[a], cl.order[b]);
      }
    }
  }
  return met;
}

// The window cell a centre falls in, from the list's own grid.
int cell_of(const CellList &cl, const Box &box, const Vec3 &r) {
  const double side[3] = {box.length.x, box.length.y, box.length.z};
  const double at[3] = {r.x, r.y, r.z};
  int w[3];
  for (int a = 0; a < 3; ++a) {
    const int k = std::clamp(static_cast<int>(Box::wrap(at[a], side[a]) / side[a] * cl.cells[a]), 0,
                             cl.cells[a] - 1);
    w[a] = (k - cl.origin[a] + cl.cells[a]) % cl.cells[a];
    EXPECT_LT(w[a], cl.extent[a]) << "a body outside the window, axis " << a;
  }
  return cl.cell_index(w[0], w[1], w[2]);
}

// Builds the list and checks the binning and the pairs; returns the list.
CellList check(const Particles &p, const Box &box, double reach, bool fit) {
  CellList cl;
  build_cell_list(cl, p, p.size(), box, reach, fit);
  // Binning: order is a permutation of the bodies, each in the cell its centre falls in.
  EXPECT_EQ(cl.cell_start.size(), static_cast<std::size_t>(cl.cell_count()) + 1);
  EXPECT_EQ(cl.cell_start.back(), p.size());
  std::vector<std::uint32_t> sorted = cl.order;
  std::sort(sorted.begin(), sorted.end());
  for (std::uint32_t i = 0; i < sorted.size(); ++i) EXPECT_EQ(sorted[i], i);
  for (int c = 0; c < cl.cell_count(); ++c)
    for (std::uint32_t k = cl.cell_start[c]; k < cl.cell_start[c + 1]; ++k)
      EXPECT_EQ(cell_of(cl, box, p.position(cl.order[k])), c) << "body " << cl.order[k];
  // The stencil: distinct offsets, {0, 0, 0} among them, and distinct cells from any cell.
  const std::set<std::array<int, 3>> offsets(cl.stencil.begin(), cl.stencil.end());
  EXPECT_EQ(offsets.size(), cl.stencil.size());
  EXPECT_TRUE(offsets.count({0, 0, 0}));
  // It is the product of the axes' offsets, x fastest (the neighbour list walks it so).
  std::vector<std::array<int, 3>> product;
  for (int a = 0; a < 3; ++a) EXPECT_LE(cl.axis_offsets[a].size(), kMaxAxisOffsets);
  for (int oz : cl.axis_offsets[2])
    for (int oy : cl.axis_offsets[1])
      for (int ox : cl.axis_offsets[0]) product.push_back({ox, oy, oz});
  EXPECT_EQ(product, cl.stencil);
  for (int c = 0; c < cl.cell_count(); ++c) {
    std::set<int> reached;
    int inside = 0;
    for (const auto &o : cl.stencil) {
      const int nc = cl.neighbour(c % cl.extent[0], (c / cl.extent[0]) % cl.extent[1],
                                  c / (cl.extent[0] * cl.extent[1]), o);
      if (nc < 0) continue;
      ++inside;
      reached.insert(nc);
    }
    EXPECT_EQ(static_cast<int>(reached.size()), inside) << "a cell visited twice from " << c;
  }
  // Every pair within reach met exactly once; no pair met twice.
  const std::map<Pair, int> met = walk(cl);
  for (const auto &[pair, times] : met) EXPECT_EQ(times, 1) << pair.first << "-" << pair.second;
  for (const Pair &pair : brute_force(p, box, reach))
    EXPECT_TRUE(met.count(pair)) << "missed " << pair.first << "-" << pair.second;
  return cl;
}

TEST(CellList, EveryPairWithinReachOnceInALargeBox) {
  Box box;
  box.length = {31.0, 27.5, 29.0};
  const Particles p = centres(600, box, 1);
  for (const bool fit : {false, true}) {
    SCOPED_TRACE(fit ? "fit" : "no fit");
    const CellList cl = check(p, box, 6.3, fit);
    EXPECT_TRUE(cl.full_stencil);
    EXPECT_EQ(cl.extent, cl.cells);  // a gas fills every axis: the window is the box
  }
}

// Dense enough for two cells per reach (16 bodies or more per occupied cell of one per reach):
// the 5 x 5 x 5 stencil; sparse: one cell per reach and 3 x 3 x 3.
TEST(CellList, TwoCellsPerReachOnlyWhereDense) {
  Box box;
  box.length = {20.0, 20.0, 20.0};
  const double reach = 4.0;
  const CellList dense = check(centres(2200, box, 2), box, reach, true);
  EXPECT_EQ(dense.cells, (std::array<int, 3>{10, 10, 10}));
  EXPECT_EQ(dense.stencil.size(), 125u);
  const CellList sparse = check(centres(300, box, 3), box, reach, true);
  EXPECT_EQ(sparse.cells, (std::array<int, 3>{5, 5, 5}));
  EXPECT_EQ(sparse.stencil.size(), 27u);
  // Without fit the count of bodies does not matter: two cells per reach where there is room.
  EXPECT_EQ(check(centres(300, box, 3), box, reach, false).cells, (std::array<int, 3>{10, 10, 10}));
}

// Boxes of one, two, three and four cells per axis: the stencil is reduced so that no cell
// is visited twice through the wrap, and pairs still meet once.
TEST(CellList, SmallBoxesReduceTheStencil) {
  const double reach = 6.0;
  for (const double side : {5.0, 7.0, 12.5, 13.0, 19.0, 25.0}) {
    SCOPED_TRACE("side " + std::to_string(side));
    Box box;
    box.length = {side, 2.0 * side, 13.0};
    const CellList cl = check(centres(80, box, 4), box, reach, false);
    check(centres(80, box, 4), box, reach, true);
    for (int a = 0; a < 3; ++a) EXPECT_GE(cl.cells[a], 1);
    if (side < 2.0 * reach) {
      EXPECT_FALSE(cl.full_stencil);
    }
  }
}

// A few bodies in a large box: most cells empty, and with fit a window around the bodies.
TEST(CellList, EmptyCellsAndTheFittedWindow) {
  Box box;
  box.length = {60.0, 60.0, 60.0};
  const CellList gas = check(centres(40, box, 5), box, 5.0, true);
  int empty = 0;
  for (int c = 0; c < gas.cell_count(); ++c) empty += gas.cell_start[c + 1] == gas.cell_start[c];
  EXPECT_GT(empty, gas.cell_count() / 2);

  // Bodies in a slab across the periodic boundary (x in [-0.1, 0.1) of the box): the window
  // along x is the few cells around x = 0, and cells outside it are -1 from the stencil.
  const Particles slab = centres(400, box, 6, -0.1, 0.1);
  const CellList cl = check(slab, box, 5.0, true);
  EXPECT_LT(cl.extent[0], cl.cells[0]);
  EXPECT_LT(cl.extent[1], cl.cells[1]);
  bool outside = false;
  for (const auto &o : cl.stencil) outside = outside || cl.neighbour(0, 0, 0, o) < 0;
  EXPECT_TRUE(outside) << "a window cell at the edge has stencil cells outside the window";
  check(slab, box, 5.0, false);  // without fit: the whole box
}

// Unfolded centres (far outside the box, negative) bin into the cell of their image.
TEST(CellList, CentresOutsideTheBoxBinByTheirImage) {
  Box box;
  box.length = {22.0, 24.0, 26.0};
  check(centres(500, box, 7, -3.0, 4.0), box, 5.5, false);
  check(centres(500, box, 7, -3.0, 4.0), box, 5.5, true);
}

TEST(CellList, NoBodiesAndOneBody) {
  Box box;
  box.length = {20.0, 20.0, 20.0};
  for (const bool fit : {false, true}) {
    const CellList none = check(Particles{}, box, 5.0, fit);
    EXPECT_TRUE(none.order.empty());
    const CellList one = check(centres(1, box, 8), box, 5.0, fit);
    EXPECT_EQ(one.order.size(), 1u);
  }
}

}  // namespace
}  // namespace hardrod
