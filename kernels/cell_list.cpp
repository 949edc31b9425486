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

// The shortest periodic run of cells holding every occupied one: it starts after the
// longest run of empty cells (the first of equals). All occupied, or none: the whole axis.
void occupied_window(const std::vector<char> &occupied, int &origin, int &extent) {
  const int n = static_cast<int>(occupied.size());
  int longest = 0, after = 0, run = 0;
  for (int k = 0; k < 2 * n; ++k) {  // twice round, so a gap across the wrap is whole
    if (!occupied[static_cast<std::size_t>(k % n)]) {
      run = std::min(run + 1, n);
    } else {
      if (run > longest) longest = run, after = k % n;
      run = 0;
    }
  }
  if (longest == 0 || run == n) {  // no gap, or no body
    origin = 0;
    extent = n;
  } else {
    origin = after;
    extent = n - longest;
  }
}

// Cells per axis for k cells per reach.
std::array<int, 3> grid_for(const std::array<double, 3> &side, double reach, int k) {
  std::array<int, 3> n{};
  for (int a = 0; a < 3; ++a)
    n[a] = std::max(1, static_cast<int>(std::floor(side[a] / (reach / k))));
  return n;
}

// Per axis, each body's cell coordinate in grid n, and which cells hold a body.
void coordinates(const Particles &p, std::size_t count, const std::array<double, 3> &side,
                 const std::array<int, 3> &n, std::array<std::vector<int>, 3> &at,
                 std::array<std::vector<char>, 3> &occupied) {
  const double *x[3] = {p.x.data(), p.y.data(), p.z.data()};
  for (int a = 0; a < 3; ++a) {
    at[a].resize(count);
    occupied[a].assign(static_cast<std::size_t>(n[a]), 0);
  }
  // The coordinates (a division and a rounding each) on the team, above a few thousand
  // bodies; which cells hold a body after, in one thread.
  const long m = static_cast<long>(count);
#pragma omp parallel for schedule(static) if (m > 4096)
  for (long i = 0; i < m; ++i)
    for (int a = 0; a < 3; ++a) at[a][i] = cell_coordinate(x[a][i], side[a], n[a]);
  for (int a = 0; a < 3; ++a)
    for (std::size_t i = 0; i < count; ++i) occupied[a][static_cast<std::size_t>(at[a][i])] = 1;
}

// Two cells per reach (a 125-cell stencil that reaches less volume) where every axis has room
// for it and the bodies are dense enough: at least 16 per occupied cell of one per reach,
// counted over the occupied window (the cells themselves, not the box, so this stays local to
// a rank too). Leaves the coordinates of the one-per-reach grid it counted in `at`, `occupied`
// and `binned` (zeros if it counted none).
int cells_per_reach(const Particles &p, std::size_t count, const std::array<double, 3> &side,
                    double reach, bool fit, std::array<std::vector<int>, 3> &at,
                    std::array<std::vector<char>, 3> &occupied, std::array<int, 3> &binned) {
  for (int a = 0; a < 3; ++a)
    if (std::floor(side[a] / (reach / 2)) < 5) return 1;
  if (!fit || count == 0) return 2;
  const auto n = binned = grid_for(side, reach, 1);
  coordinates(p, count, side, n, at, occupied);
  std::array<int, 3> origin{}, extent{};
  for (int a = 0; a < 3; ++a) occupied_window(occupied[a], origin[a], extent[a]);
  std::vector<char> seen(static_cast<std::size_t>(extent[0]) * extent[1] * extent[2], 0);
  std::size_t filled = 0;
  for (std::size_t i = 0; i < count; ++i) {
    std::size_t c = 0;
    for (int a = 2; a >= 0; --a) {
      int w = at[a][i] - origin[a];
      if (w < 0) w += n[a];
      c = c * static_cast<std::size_t>(extent[a]) + static_cast<std::size_t>(w);
    }
    filled += !seen[c];
    seen[c] = 1;
  }
  return count < 16 * filled ? 1 : 2;
}

// The stencil of k cells per reach: the offsets per axis and their product.
void set_stencil(CellList &list, int k) {
  list.full_stencil = true;
  for (int a = 0; a < 3; ++a) list.full_stencil &= list.cells[a] >= 2 * k + 1;
  for (int a = 0; a < 3; ++a) list.axis_offsets[a] = axis_offsets(list.cells[a], k);
  list.stencil.clear();
  for (int oz : list.axis_offsets[2])
    for (int oy : list.axis_offsets[1])
      for (int ox : list.axis_offsets[0]) list.stencil.push_back({ox, oy, oz});
}

// Bodies [0, count) into their window cells by a counting sort on the cell coordinates `at`:
// cell_start, and order (each cell's bodies in rising index).
void bin_bodies(CellList &list, const std::array<std::vector<int>, 3> &at, std::size_t count) {
  const int ncells = list.cell_count();
  std::vector<std::uint32_t> cell_of(count);
  list.cell_start.assign(static_cast<std::size_t>(ncells) + 1, 0);
  for (std::size_t i = 0; i < count; ++i) {
    int w[3];
    for (int a = 0; a < 3; ++a) {
      w[a] = at[a][i] - list.origin[a];
      if (w[a] < 0) w[a] += list.cells[a];
    }
    const int c = list.cell_index(w[0], w[1], w[2]);
    cell_of[i] = static_cast<std::uint32_t>(c);
    ++list.cell_start[static_cast<std::size_t>(c) + 1];
  }
  for (int c = 0; c < ncells; ++c) list.cell_start[c + 1] += list.cell_start[c];
  list.order.resize(count);
  std::vector<std::uint32_t> fill(list.cell_start.begin(), list.cell_start.end() - 1);
  for (std::size_t i = 0; i < count; ++i)
    list.order[fill[cell_of[i]]++] = static_cast<std::uint32_t>(i);
}

}  // namespace

void build_cell_list(CellList &list, const Particles &p, std::size_t count, const Box &box,
                     double reach, bool fit) {
  const std::array<double, 3> side{box.length.x, box.length.y, box.length.z};
  std::array<std::vector<int>, 3> at;  // each body's cell coordinates in grid `binned`
  std::array<std::vector<char>, 3> occupied;
  std::array<int, 3> binned{0, 0, 0};
  const int k = cells_per_reach(p, count, side, reach, fit, at, occupied, binned);
  list.cells = grid_for(side, reach, k);
  set_stencil(list, k);
  if (binned != list.cells) coordinates(p, count, side, list.cells, at, occupied);
  if (fit && count > 0) {
    for (int a = 0; a < 3; ++a) occupied_window(occupied[a], list.origin[a], list.extent[a]);
  } else {
    list.origin = {0, 0, 0};
    list.extent = list.cells;
  }
  bin_bodies(list, at, count);
}

}  // namespace hardrod
