// Linked-cell binning of body centres: the broad phase that feeds the neighbour list.
// Cells are at least `reach / reach_cells` wide, and the stencil spans reach_cells cells
// each way, so every pair closer than `reach` lies within the stencil. Two cells per reach
// (when every axis has room for five) cut the candidates about 1.7-fold against one, but
// visit 125 cells per cell instead of 27.
// With `fit` (the neighbour list):
//   - two cells per reach only where the occupied cells of one per reach hold 16 bodies or
//     more on average (the nematic's ~25; a dense hard-sphere fluid's ~2 and a gas's ~0.2
//     take one);
//   - the cells are stored only over a window: per axis the shortest periodic run of
//     cells that holds every body. A rank holds its subdomain and halo, not the box, so its
//     memory and its passes over cells follow its own bodies, not the whole system's.
// Cells outside the window are empty; `neighbour` says so with -1. Axes with too few cells
// get a reduced stencil so no cell is visited twice through the periodic wrap. Output:
// bodies sorted by cell (counting sort). Serial: runs on rebuilds.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"

namespace hardrod {

// Offsets along one axis of the stencil: -k..k for k = 2 cells per reach, or fewer.
inline constexpr std::size_t kMaxAxisOffsets = 5;

struct CellList {
  std::array<int, 3> cells{1, 1, 1};   // cells per axis over the whole box
  std::array<int, 3> origin{0, 0, 0};  // the window's first cell per axis (box coordinates)
  std::array<int, 3> extent{1, 1, 1};  // the window's cells per axis (all of them without fit)
  std::vector<std::uint32_t>
      cell_start;                    // bodies of cell c: order[cell_start[c] .. cell_start[c+1])
  std::vector<std::uint32_t> order;  // body indices sorted by cell
  std::vector<std::array<int, 3>> stencil;  // distinct neighbour offsets, including {0,0,0}
  // The stencil's offsets along each axis (at most kMaxAxisOffsets): the stencil is their
  // product, x fastest and z slowest, so a walk may take the axes one at a time.
  std::array<std::vector<int>, 3> axis_offsets;
  // Every axis has the full stencil (-k..k, 2k + 1 cells or more): the box is wider than
  // twice the reach, so a pair within reach has one periodic image.
  bool full_stencil = false;

  // Cells of the window, indexed by window coordinates (0 .. extent - 1 per axis).
  int cell_count() const { return extent[0] * extent[1] * extent[2]; }
  int cell_index(int cx, int cy, int cz) const { return (cz * extent[1] + cy) * extent[0] + cx; }
  // Box coordinate along axis a of window coordinate c.
  int box_coordinate(int a, int c) const {
    const int g = origin[a] + c;
    return g >= cells[a] ? g - cells[a] : g;
  }
  // Window cell of neighbour offset `o` from window cell (cx, cy, cz), periodic; -1 when it
  // lies outside the window (no bodies there). Stencil offsets stay within one box length
  // (|o| < cells), so one add or subtract wraps.
  int neighbour(int cx, int cy, int cz, const std::array<int, 3> &o) const {
    const int c[3] = {cx, cy, cz};
    int w[3];
    for (int a = 0; a < 3; ++a) {
      int k = c[a] + o[a];  // relative to the origin, periodic in the box
      k = k < 0 ? k + cells[a] : (k >= cells[a] ? k - cells[a] : k);
      if (k >= extent[a]) return -1;
      w[a] = k;
    }
    return cell_index(w[0], w[1], w[2]);
  }
};

void build_cell_list(CellList &list, const Particles &p, std::size_t count, const Box &box,
                     double reach, bool fit = false);

}  // namespace hardrod
