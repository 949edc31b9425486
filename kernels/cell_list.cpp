#include "kernels/cell_list.hpp"

#include <algorithm>
#include <cmath>

namespace hardrod {

namespace {

// Offsets along one axis that reach distinct cells: -k..k when the axis has 2k + 1 cells
// or more; otherwise every cell once (offsets 0 .. cells - 1).
std::vector<int> axis_offsets(int cells, int k) {
  std::vector<int> out;
  if (cells >= 2 * k + 1) {
    for (int o = -k; o <= k; ++o) out.push_back(o);
  } else {
    for (int o = 0; o < cells; ++o) out.push_back(o);
  }
  return out;
}

int cell_coordinate(double c, double side, int cells) {
  const int k = static_cast<int>(Box::wrap(c, side) / side * cells);
  return std::clamp(k, 0, cells - 1);  // c == side after rounding, or tiny negatives
}

}  // namespace

void build_cell_list(CellList &list, const Particles &p, std::size_t count, const Box &box,
                     double reach, bool by_occupancy) {
  const std::array<double, 3> side{box.length.x, box.length.y, box.length.z};
  int k = 2;  // cells per reach
  for (int a = 0; a < 3; ++a)
    if (std::floor(side[a] / (reach / 2)) < 5) k = 1;
  if (k == 2 && by_occupancy && count > 0) {
    // Bodies per occupied cell of one cell per reach (occupied: a rank holds only its
    // subdomain and halo of the box).
    std::array<int, 3> n{};
    for (int a = 0; a < 3; ++a) n[a] = std::max(1, static_cast<int>(std::floor(side[a] / reach)));
    std::vector<char> seen(static_cast<std::size_t>(n[0]) * n[1] * n[2], 0);
    std::size_t occupied = 0;
    for (std::size_t i = 0; i < count; ++i) {
      const std::size_t c =
          (static_cast<std::size_t>(cell_coordinate(p.z[i], side[2], n[2])) * n[1] +
           cell_coordinate(p.y[i], side[1], n[1])) *
              n[0] +
          cell_coordinate(p.x[i], side[0], n[0]);
      occupied += !seen[c];
      seen[c] = 1;
    }
    if (count < 16 * occupied) k = 1;
  }
  for (int a = 0; a < 3; ++a)
    list.cells[a] = std::max(1, static_cast<int>(std::floor(side[a] / (reach / k))));

  list.full_stencil = true;
  for (int a = 0; a < 3; ++a) list.full_stencil &= list.cells[a] >= 2 * k + 1;
  list.stencil.clear();
  for (int oz : axis_offsets(list.cells[2], k))
    for (int oy : axis_offsets(list.cells[1], k))
      for (int ox : axis_offsets(list.cells[0], k)) list.stencil.push_back({ox, oy, oz});

  const int ncells = list.cell_count();
  std::vector<std::uint32_t> cell_of(count);
  list.cell_start.assign(static_cast<std::size_t>(ncells) + 1, 0);
  for (std::size_t i = 0; i < count; ++i) {
    const int c = list.cell_index(cell_coordinate(p.x[i], side[0], list.cells[0]),
                                  cell_coordinate(p.y[i], side[1], list.cells[1]),
                                  cell_coordinate(p.z[i], side[2], list.cells[2]));
    cell_of[i] = static_cast<std::uint32_t>(c);
    ++list.cell_start[static_cast<std::size_t>(c) + 1];
  }
  for (int c = 0; c < ncells; ++c) list.cell_start[c + 1] += list.cell_start[c];
  list.order.resize(count);
  std::vector<std::uint32_t> fill(list.cell_start.begin(), list.cell_start.end() - 1);
  for (std::size_t i = 0; i < count; ++i)
    list.order[fill[cell_of[i]]++] = static_cast<std::uint32_t>(i);
}

}  // namespace hardrod
