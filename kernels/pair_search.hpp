// The pairs of one neighbour-list build (kernels/neighbor_list.hpp): every pair of bodies
// [0, count) of the cell list whose axis segments are closer than D + skin, with its slack, in
// cell order (which is body order after the build's sort) for any thread count; no pair of two
// shadows (bodies from `owned` on). Threads take runs of cells.
#pragma once

#include <cstddef>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/cell_list.hpp"
#include "kernels/neighbor_list.hpp"
#include "kernels/particles.hpp"
#include "kernels/shape.hpp"

namespace hardrod {

void find_pairs(const Particles &p, const Box &box, const Shape &shape, const CellList &cells,
                double skin, std::size_t owned, std::vector<ListedPair> &pairs);

}  // namespace hardrod
