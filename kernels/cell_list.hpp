// Linked-cell binning of body centres: the broad phase that feeds the neighbour list.
// Cells are at least `reach / reach_cells` wide, and the stencil spans reach_cells cells
// each way, so every pair closer than `reach` lies within the stencil. Two cells per reach
// (when every axis has room for five) cut the candidates about 1.7-fold against one, but
// visit 125 cells per cell instead of 27: with `by_occupancy`, two only where the occupied
// cells of one-per-reach hold 16 bodies or more on average (the nematic's ~25; a dense
// hard-sphere fluid's ~2 and a gas's ~0.2 take one).
// Axes with too few cells get a reduced stencil so no cell is visited twice through the
// periodic wrap. Output: bodies sorted by cell (counting sort). Serial: runs on rebuilds.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"

namespace hardrod {

struct CellList {
  std::array<int, 3> cells{1, 1, 1};  // cells per axis
  std::vector<std::uint32_t>
      cell_start;                    // bodies of cell c: order[cell_start[c] .. cell_start[c+1])
  std::vector<std::uint32_t> order;  // body indices sorted by cell
  std::vector<std::array<int, 3>> stencil;  // distinct neighbour offsets, including {0,0,0}
  // Every axis has the full stencil (-k..k, 2k + 1 cells or more): the box is wider than
  // twice the reach, so a pair within reach has one periodic image.
  bool full_stencil = false;

  int cell_count() const { return cells[0] * cells[1] * cells[2]; }
  int cell_index(int cx, int cy, int cz) const { return (cz * cells[1] + cy) * cells[0] + cx; }
  // Cell of neighbour offset `o` from cell (cx, cy, cz), periodic.
  // Stencil offsets stay within one box length (|o| < cells), so one add or subtract wraps.
  int neighbour(int cx, int cy, int cz, const std::array<int, 3> &o) const {
    const auto wrap = [](int c, int n) { return c < 0 ? c + n : (c >= n ? c - n : c); };
    return cell_index(wrap(cx + o[0], cells[0]), wrap(cy + o[1], cells[1]),
                      wrap(cz + o[2], cells[2]));
  }
};

void build_cell_list(CellList &list, const Particles &p, std::size_t count, const Box &box,
                     double reach, bool by_occupancy = false);

}  // namespace hardrod
