// Linked-cell binning of body centres: the broad phase that feeds the neighbour list.
// Cells are at least `min_side` wide (interaction range plus skin), so every pair that can
// touch lies in the same or an adjacent cell. Dimensions with fewer than three cells get a
// reduced stencil so that no cell is visited twice through the periodic wrap.
// Inputs: centres (folded into the box). Output: bodies sorted by cell (counting sort).
// Serial: it runs only when the neighbour list is rebuilt.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"

namespace hardrod {

struct CellList {
  std::array<int, 3> cells{1, 1, 1};          // cells per axis
  std::vector<std::uint32_t> cell_start;      // bodies of cell c: order[cell_start[c] .. cell_start[c+1])
  std::vector<std::uint32_t> order;           // body indices sorted by cell
  std::vector<std::array<int, 3>> stencil;    // distinct neighbour offsets, including {0,0,0}

  int cell_count() const { return cells[0] * cells[1] * cells[2]; }
  int cell_index(int cx, int cy, int cz) const { return (cz * cells[1] + cy) * cells[0] + cx; }
  // Cell of neighbour offset `o` from cell (cx, cy, cz), periodic.
  int neighbour(int cx, int cy, int cz, const std::array<int, 3> &o) const;
};

void build_cell_list(CellList &list, const Particles &p, std::size_t count, const Box &box,
                     double min_side);

}  // namespace hardrod
