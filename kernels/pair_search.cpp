// The pairs of one list build (pair_search.hpp): cell by cell, a preselection, the exact tests.
#include "kernels/pair_search.hpp"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "kernels/segment_geometry.hpp"

namespace hardrod {

namespace {

// What the search for pairs reads, fixed for one build.
// Where every axis has the full stencil, a pair within reach has one periodic image, and
// the cell it was found through says which: candidates are gathered per cell from folded
// centres shifted by whole box lengths, and measured without a rounding per coordinate
// (box.minimum_image). This only preselects: the survivors are measured exactly as
// without it, from minimum_image, so the pairs and their slacks are those of that test alone.
struct PairSearch {
  PairSearch(const Particles &p, const Box &box, const Shape &shape, const CellList &cl,
             double skin, std::size_t owned);
  const Particles &p;
  const Box &box;
  const CellList &cl;
  Vec3 inverse;
  double diameter, h;
  bool rods, unique_images;
  // Bodies [0, owned) are this rank's own, the rest shadows: a pair of two shadows is not
  // searched (keep_first_ring would drop it).
  std::uint32_t owned;
  std::array<double, 3> side;
  double reach;          // segment distance kept in the list
  double centre_reach2;  // centres further apart than (L + reach) cannot be within reach
  double prefilter_reach2;
  // The rods' preselection (preselect_rods) runs in single precision, on centres taken
  // relative to the searched cell's first body, and keeps a margin more than the reach:
  // `loose` for the segments, `gather` for the centres (reach_margin).
  float gather_reach2, loose_reach2, h_single;
  // Rods with unique_images: their folded centres (and axes, in single precision: only the
  // preselection reads them) in cell order (entry b is body order[b]), so that a run of cells
  // is a run of entries, and its candidates are copied in vector lanes without an index per
  // value. The storage is kept from build to build.
  struct CellOrdered {
    std::vector<double> x, y, z;
    std::vector<float> ex, ey, ez;
  };
  CellOrdered &ordered;
};

// How much more than the reach the rods' single-precision preselection keeps. A candidate's
// centre lies within (k + 1) cell sides of the searched cell's first body on every axis
// (k: the stencil's offsets each way), so its relative coordinates, and every length the
// test forms from them, are below M = sqrt(3) (k + 1) (largest side). Each is rounded to
// single precision (2^-24 M) and goes through a dozen operations: a length compared is off by
// well under 1e-6 M. The margin, 1e-5 M plus 1e-4 of the reach (~4e-4 D in the nematic), is
// over ten times that, so every pair the exact test (list_pairs) would list is kept; the few
// more it keeps, that test drops.
double reach_margin(const CellList &cl, const Box &box, double reach) {
  const double side[3] = {box.length.x, box.length.y, box.length.z};
  double extent = 0.0;
  for (int a = 0; a < 3; ++a) {
    const double k = static_cast<double>(cl.axis_offsets[a].size() / 2);
    extent = std::max(extent, (k + 1.0) * side[a] / cl.cells[a]);
  }
  return 1e-4 * reach + 1e-5 * std::sqrt(3.0) * extent;
}

// The builder's storage for PairSearch::ordered (the builds of one thread share it).
PairSearch::CellOrdered &kept_ordered() {
  thread_local PairSearch::CellOrdered storage;
  return storage;
}

PairSearch::PairSearch(const Particles &p, const Box &box, const Shape &shape, const CellList &cl,
                       double skin, std::size_t owned)
    : p(p),
      box(box),
      cl(cl),
      inverse(box.inverse_length()),
      diameter(shape.diameter),
      h(shape.half_length()),
      rods(!shape.is_sphere()),
      unique_images(cl.full_stencil),
      owned(static_cast<std::uint32_t>(owned)),
      side{box.length.x, box.length.y, box.length.z},
      reach(shape.diameter + skin),
      ordered(kept_ordered()) {
  const double centre_reach = shape.length + reach;
  centre_reach2 = centre_reach * centre_reach;
  prefilter_reach2 = (reach + 1e-7) * (reach + 1e-7);
  const double margin = reach_margin(cl, box, reach);
  gather_reach2 = static_cast<float>((centre_reach + margin) * (centre_reach + margin));
  loose_reach2 = static_cast<float>((reach + margin) * (reach + margin));
  h_single = static_cast<float>(h);
  if (!unique_images || !rods) return;  // spheres: raw centres, by index (list_spheres)
  const std::uint32_t *order = cl.order.data();
  const std::size_t n = cl.order.size();
  CellOrdered &o = ordered;
  o.x.resize(n), o.y.resize(n), o.z.resize(n);
  o.ex.resize(n), o.ey.resize(n), o.ez.resize(n);
  for (std::size_t b = 0; b < n; ++b) {
    const std::uint32_t i = order[b];
    o.x[b] = Box::wrap(p.x[i], side[0]);
    o.y[b] = Box::wrap(p.y[i], side[1]);
    o.z[b] = Box::wrap(p.z[i], side[2]);
    o.ex[b] = static_cast<float>(p.ex[i]);
    o.ey[b] = static_cast<float>(p.ey[i]);
    o.ez[b] = static_cast<float>(p.ez[i]);
  }
}

// One thread's scratch for the cells it searches; grown, never shrunk (no refills).
struct CellScratch {
  // Bodies order[begin, end) of one or more consecutive cells, and the shift of their folded
  // centres next to the searched cell.
  struct Run {
    std::uint32_t begin, end;
    double sx, sy, sz;
  };
  // runs[0, run_count): the searched cell first, then its later neighbours. Sized for the
  // whole stencil once, not per cell (a resize would clear every new run again).
  std::vector<Run> runs;
  std::size_t run_count = 0;
  // The cell's own bodies, then those of the stencil's later cells (nc > c): body a of
  // the cell meets the candidates after it, so each unordered pair is taken once.
  std::vector<std::uint32_t> cand;
  // Their centres (unique_images): spheres' raw (cx, cy, cz); rods' folded, shifted next to
  // the cell and taken relative to its first body, in single precision (fx, fy, fz), with
  // their axes (fex, fey, fez).
  std::vector<double> cx, cy, cz;
  std::vector<float> fx, fy, fz, fex, fey, fez;
  // 1 for a candidate kept by the preselection (as wide as a float: the vector loop that
  // writes it then runs sixteen candidates at a time)
  std::vector<std::uint32_t> keep;
  std::vector<std::uint32_t> near;    // candidates kept for the exact test
  std::vector<double> distance;       // and their segment distances (list_pairs)
  std::vector<std::uint64_t> within;  // 1 for those within reach
};

// One thread's pairs as found: [0, count) of `pairs`, whose storage only grows (kept from build
// to build), so a body's pairs are written in place without a branch per candidate.
struct FoundPairs {
  std::vector<ListedPair> pairs;
  std::size_t count = 0;
  // Room for `need` more pairs after [0, count).
  ListedPair *room(std::size_t need) {
    if (pairs.size() < count + need) pairs.resize(std::max(2 * pairs.size(), count + need));
    return pairs.data() + count;
  }
};

// The stencil along one axis from window coordinate `at`: for each offset, the window
// coordinate of the cell it reaches (-1 outside the window, where there are no bodies) and
// the shift that brings that cell's folded centres next to this cell. As CellList::neighbour
// wraps: stencil offsets stay within one box length, so one add or subtract does.
struct AxisReach {
  int count = 0;
  int at[kMaxAxisOffsets];
  double shift[kMaxAxisOffsets];
};

AxisReach axis_reach(const PairSearch &s, int axis, int at) {
  const CellList &cl = s.cl;
  const int n = cl.cells[axis], window = cl.extent[axis];
  const int from = cl.box_coordinate(axis, at);
  const double length = s.side[axis];
  AxisReach r;
  for (int o : cl.axis_offsets[axis]) {
    int k = at + o;
    k = k < 0 ? k + n : (k >= n ? k - n : k);
    const int b = from + o;
    r.at[r.count] = k >= window ? -1 : k;
    r.shift[r.count++] = b < 0 ? -length : (b >= n ? length : 0.0);
  }
  return r;
}

// later_cells for a cell whose stencil (-k..k on every axis) lies inside the window and
// inside the box, without a periodic wrap: every row of the stencil's later cells is one run
// of consecutive cells, unshifted, and the rows come in the same order as later_cells takes
// them (so the same candidates in the same order). Returns false for any other cell.
bool later_cells_inside(const PairSearch &s, int c, CellScratch &w) {
  const CellList &cl = s.cl;
  if (!cl.full_stencil) return false;
  const int k = static_cast<int>(cl.axis_offsets[0].size() / 2);
  const int ex = cl.extent[0], ey = cl.extent[1];
  const int at[3] = {c % ex, (c / ex) % ey, c / (ex * ey)};
  for (int a = 0; a < 3; ++a) {
    const int from = cl.origin[a] + at[a];  // box coordinate before the wrap
    if (at[a] < k || at[a] + k >= cl.extent[a] || from - k < 0 || from + k >= cl.cells[a])
      return false;
  }
  const std::uint32_t *__restrict start = cl.cell_start.data();
  if (w.runs.size() < 1 + cl.stencil.size()) w.runs.resize(1 + cl.stencil.size());
  CellScratch::Run *__restrict out = w.runs.data();
  std::size_t n = 0;
  out[n++] = {start[c], start[c + k + 1], 0.0, 0.0, 0.0};  // c, then its row's later cells
  for (int dy = 1; dy <= k; ++dy) {
    const int row = c + dy * ex;
    out[n++] = {start[row - k], start[row + k + 1], 0.0, 0.0, 0.0};
  }
  for (int dz = 1; dz <= k; ++dz)
    for (int dy = -k; dy <= k; ++dy) {
      const int row = c + (dz * ey + dy) * ex;
      out[n++] = {start[row - k], start[row + k + 1], 0.0, 0.0, 0.0};
    }
  w.run_count = n;
  return true;
}

// The bodies of cell c, then those of the stencil's cells after it (nc > c), into w.runs in
// stencil order (w.run_count of them). The stencil reaches distinct cells, so visiting only cells
// nc >= c (and, in c itself, only later bodies) takes each unordered pair exactly once. Axis by
// axis (the stencil is the product of the axes' offsets): the wrap and the shift are worked out 3 x
// 5 times per cell rather than for each of the 125 offsets. Cells whose bodies follow the previous
// run's in `order` with the same shift (neighbours along x, mostly) extend it: a nematic's cells
// hold ~3 bodies, too few for a copy loop per cell to pay.
void later_cells(const PairSearch &s, int c, CellScratch &w) {
  if (later_cells_inside(s, c, w)) return;
  const CellList &cl = s.cl;
  const std::uint32_t *__restrict start = cl.cell_start.data();
  const int ex = cl.extent[0], ey = cl.extent[1];
  const AxisReach x = axis_reach(s, 0, c % ex), y = axis_reach(s, 1, (c / ex) % ey),
                  z = axis_reach(s, 2, c / (ex * ey));
  if (w.runs.size() < 1 + cl.stencil.size()) w.runs.resize(1 + cl.stencil.size());
  CellScratch::Run *__restrict out = w.runs.data();
  std::size_t n = 0;
  out[n++] = {start[c], start[c + 1], 0.0, 0.0, 0.0};
  for (int kz = 0; kz < z.count; ++kz) {
    if (z.at[kz] < 0) continue;
    for (int ky = 0; ky < y.count; ++ky) {
      if (y.at[ky] < 0) continue;
      const int row = (z.at[kz] * ey + y.at[ky]) * ex;
      for (int kx = 0; kx < x.count; ++kx) {
        const int nc = row + x.at[kx];
        if (x.at[kx] < 0 || nc <= c || start[nc] == start[nc + 1]) continue;
        CellScratch::Run &last = out[n - 1];
        if (start[nc] == last.end && x.shift[kx] == last.sx && y.shift[ky] == last.sy &&
            z.shift[kz] == last.sz)
          last.end = start[nc + 1];
        else
          out[n++] = {start[nc], start[nc + 1], x.shift[kx], y.shift[ky], z.shift[kz]};
      }
    }
  }
  w.run_count = n;
}

// A run of n entries (cell order, from b0) into the candidates from q, their centres shifted
// by (sx, sy, sz) and taken relative to `from`. Loops over all the values at once, so that
// they vectorise without alias checks (the runs are ~20 long; a loop per array became a
// library call).
inline void copy_rods(const PairSearch &s, std::size_t b0, std::size_t n, double sx, double sy,
                      double sz, const Vec3 &from, CellScratch &w, std::size_t q) {
  const std::uint32_t *__restrict member = s.cl.order.data() + b0;
  std::uint32_t *__restrict cand = w.cand.data() + q;
  const PairSearch::CellOrdered &o = s.ordered;
  const double *__restrict fx = o.x.data() + b0, *__restrict fy = o.y.data() + b0,
                           *__restrict fz = o.z.data() + b0;
  const float *__restrict fex = o.ex.data() + b0, *__restrict fey = o.ey.data() + b0,
                          *__restrict fez = o.ez.data() + b0;
  float *__restrict ox = w.fx.data() + q, *__restrict oy = w.fy.data() + q,
                    *__restrict oz = w.fz.data() + q;
  float *__restrict oex = w.fex.data() + q, *__restrict oey = w.fey.data() + q,
                    *__restrict oez = w.fez.data() + q;
  const double dx = sx - from.x, dy = sy - from.y, dz = sz - from.z;
#pragma GCC ivdep  // (inlined, the restricts are lost)
  for (std::size_t t = 0; t < n; ++t) {
    cand[t] = member[t];
    ox[t] = static_cast<float>(fx[t] + dx);
    oy[t] = static_cast<float>(fy[t] + dy);
    oz[t] = static_cast<float>(fz[t] + dz);
    oex[t] = fex[t], oey[t] = fey[t], oez[t] = fez[t];
  }
}
// Spheres: their raw centres by index (a pass into cell order would cost what it saves).
inline void copy_spheres(const PairSearch &s, std::size_t b0, std::size_t n, CellScratch &w,
                         std::size_t q) {
  const std::uint32_t *__restrict member = s.cl.order.data() + b0;
  std::uint32_t *__restrict cand = w.cand.data() + q;
  const double *__restrict x = s.p.x.data(), *__restrict y = s.p.y.data(),
                           *__restrict z = s.p.z.data();
  double *__restrict ox = w.cx.data() + q, *__restrict oy = w.cy.data() + q,
                     *__restrict oz = w.cz.data() + q;
  for (std::size_t t = 0; t < n; ++t) {
    const std::uint32_t j = member[t];
    cand[t] = j, ox[t] = x[j], oy[t] = y[j], oz[t] = z[j];
  }
}

// The candidates of cell c: its bodies, then those of the stencil's cells after it. Returns
// how many are c's own.
std::uint32_t gather_cell(const PairSearch &s, int c, CellScratch &w) {
  const CellList &cl = s.cl;
  later_cells(s, c, w);
  std::size_t total = 0;
  const CellScratch::Run *runs = w.runs.data(), *runs_end = runs + w.run_count;
  for (const CellScratch::Run *r = runs; r != runs_end; ++r) total += r->end - r->begin;
  w.cand.resize(total);
  const bool unique_images = s.unique_images, rods = s.rods;
  if (unique_images && !rods) w.cx.resize(total), w.cy.resize(total), w.cz.resize(total);
  if (unique_images && rods) {
    w.fx.resize(total), w.fy.resize(total), w.fz.resize(total);
    w.fex.resize(total), w.fey.resize(total), w.fez.resize(total);
  }
  // The rods' centres relative to the cell's first body (folded): every candidate's within a
  // few cells of it, so single precision keeps them to ~1e-6 D (reach_margin).
  const std::uint32_t first = cl.cell_start[c];
  const Vec3 from = unique_images && rods
                        ? Vec3{s.ordered.x[first], s.ordered.y[first], s.ordered.z[first]}
                        : Vec3{};
  // Locals: the stores below must not make the compiler reload the search's arrays.
  const std::uint32_t *__restrict member = cl.order.data();
  const std::uint32_t *__restrict start = cl.cell_start.data();
  std::uint32_t *__restrict cand = w.cand.data();
  std::size_t q = 0;
  for (const CellScratch::Run *r = runs; r != runs_end; ++r) {
    const std::size_t b0 = r->begin, n = r->end - r->begin;
    if (unique_images && rods)
      copy_rods(s, b0, n, r->sx, r->sy, r->sz, from, w, q);
    else if (unique_images)
      copy_spheres(s, b0, n, w, q);
    else
      for (std::size_t t = 0; t < n; ++t) cand[q + t] = member[b0 + t];
    q += n;
  }
  return start[c + 1] - start[c];
}

// Listed branch-free from keep[from, ncand) into w.near, but eight at a time past the blocks
// where none is kept; with OwnedOnly, only the candidates below s.owned (a shadow's partners).
// Returns how many are kept.
template <bool OwnedOnly>
std::uint32_t list_kept(const PairSearch &s, CellScratch &w, std::uint32_t from) {
  const std::size_t ncand = w.cand.size();
  const std::uint32_t *__restrict k = w.keep.data();
  std::uint32_t *__restrict near = w.near.data();
  const std::uint32_t *__restrict cand = w.cand.data();
  const std::uint32_t owned = s.owned;
  const auto keeps = [&](std::size_t q) {
    return OwnedOnly ? k[q] & static_cast<std::uint32_t>(cand[q] < owned) : k[q];
  };
  std::size_t kept = 0, q = from;
  for (; q + 16 <= ncand; q += 16) {
    const std::uint32_t *__restrict b = k + q;
    std::uint32_t any = 0;  // sixteen flags in one vector test
#pragma omp simd reduction(| : any)
    for (std::size_t t = 0; t < 16; ++t) any |= b[t];
    if (any == 0) continue;
    for (std::size_t t = 0; t < 16; ++t) {
      near[kept] = cand[q + t];
      kept += keeps(q + t);
    }
  }
  for (; q < ncand; ++q) {
    near[kept] = cand[q];
    kept += keeps(q);
  }
  return static_cast<std::uint32_t>(kept);
}

// Rods with unique images: the centre test and the side-by-side bound (|r_perp| - h |e_j . n|
// against the reach) of candidate a against every later candidate at once: a vector loop
// writes which are kept, then they are listed in w.near. In a nematic about one candidate in
// five passes the centre test and one in ~40 both. In single precision (sixteen candidates
// a vector), looser than the exact tests of list_pairs by reach_margin, so it only drops
// pairs those would drop, and the list is that of the exact tests alone. Returns how many are
// kept.
std::uint32_t preselect_rods(const PairSearch &s, CellScratch &w, std::uint32_t a) {
  const std::uint32_t ncand = static_cast<std::uint32_t>(w.cand.size());
  const float h = s.h_single, gather_reach2 = s.gather_reach2, loose_reach2 = s.loose_reach2;
  const float xi = w.fx[a], yi = w.fy[a], zi = w.fz[a];
  const float eix = w.fex[a], eiy = w.fey[a], eiz = w.fez[a];
  if (w.keep.size() < ncand) w.keep.resize(ncand);
  std::uint32_t *__restrict k = w.keep.data();
  const float *__restrict qx = w.fx.data(), *__restrict qy = w.fy.data(),
                          *__restrict qz = w.fz.data(), *__restrict qex = w.fex.data(),
                          *__restrict qey = w.fey.data(), *__restrict qez = w.fez.data();
#pragma omp simd
  for (std::uint32_t q = a + 1; q < ncand; ++q) {
    const float dx = qx[q] - xi, dy = qy[q] - yi, dz = qz[q] - zi;
    const float s = dx * eix + dy * eiy + dz * eiz;
    const float px = dx - s * eix, py = dy - s * eiy, pz = dz - s * eiz;
    const float rp2 = px * px + py * py + pz * pz;
    const float lower = rp2 - h * std::fabs(qex[q] * px + qey[q] * py + qez[q] * pz);
    // & rather than &&: with a branch in it the loop would not vectorise.
    const bool apart = (lower > 0.0f) & (lower * lower > loose_reach2 * rp2);
    k[q] = (dx * dx + dy * dy + dz * dz < gather_reach2) & !apart;
  }
  // One candidate in ~65 is kept in the nematic, so most blocks of sixteen keep none.
  return w.cand[a] < s.owned ? list_kept<false>(s, w, a + 1) : list_kept<true>(s, w, a + 1);
}

// Spheres with unique images: list_pairs' exact test (the minimum image of the raw centres,
// their distance) of candidate a against every later candidate at once, in vector lanes, and
// the pairs within reach listed in the candidates' order. No preselection: a dense fluid keeps
// about one candidate in four, so a filter and a second pass over its survivors cost more
// than the exact test of all.
// (Not inlined: inlined, it made find_pairs too large for GCC to inline the rods' list_pairs.)
[[gnu::noinline]] void list_spheres(const PairSearch &s, CellScratch &w, std::uint32_t a,
                                    FoundPairs &mine) {
  const std::uint32_t ncand = static_cast<std::uint32_t>(w.cand.size());
  const Box box = s.box;
  const Vec3 inverse = s.inverse;
  const double reach = s.reach, centre_reach2 = s.centre_reach2;
  const double xi = w.cx[a], yi = w.cy[a], zi = w.cz[a];
  if (w.distance.size() < ncand) w.distance.resize(ncand), w.within.resize(ncand);
  double *__restrict distance = w.distance.data();
  std::uint64_t *__restrict within = w.within.data();
  const double *__restrict qx = w.cx.data(), *__restrict qy = w.cy.data(),
                           *__restrict qz = w.cz.data();
#pragma omp simd
  for (std::uint32_t q = a + 1; q < ncand; ++q) {
    const Vec3 rij = box.minimum_image({qx[q] - xi, qy[q] - yi, qz[q] - zi}, inverse);
    distance[q] = norm2(rij);  // squared here; the root only for those kept below
    within[q] = distance[q] < centre_reach2;
  }
  // Listed without a branch (one candidate in four is kept: a branch would mispredict),
  // with the distance's root for those within the centres' reach only.
  const std::uint32_t i = w.cand[a];
  if (w.near.size() < ncand) w.near.resize(ncand);
  std::uint32_t *__restrict at_q = w.near.data();
  std::uint32_t near = 0;
  if (i < s.owned) {
    for (std::uint32_t q = a + 1; q < ncand; ++q) {
      at_q[near] = q;
      near += static_cast<std::uint32_t>(within[q]);
    }
  } else {  // a shadow: its pairs with owned bodies only
    const std::uint32_t *__restrict cand = w.cand.data();
    for (std::uint32_t q = a + 1; q < ncand; ++q) {
      at_q[near] = q;
      near += static_cast<std::uint32_t>(within[q]) & static_cast<std::uint32_t>(cand[q] < s.owned);
    }
  }
  ListedPair *__restrict out = mine.room(near);
  std::size_t kept = 0;
  for (std::uint32_t k = 0; k < near; ++k) {
    const std::uint32_t q = at_q[k];
    const double d = std::sqrt(distance[q]);
    out[kept] = {i, w.cand[q], slack_below(d - s.diameter - kDistanceSafetyMargin), 0.0f};
    kept += d < reach;
  }
  mine.count += kept;
}

// The exact tests of body i against the kept candidates near[0, kept): each pair whose
// segments are within the reach is listed with its slack. The tests run in vector lanes, one
// loop without branches over the candidates (the same operations as one test at a time, so
// the same bits), and the pairs within reach are listed after, in the candidates' order.
template <bool Rods>
void list_pairs(const PairSearch &s, std::uint32_t i, const std::uint32_t *near, std::uint32_t kept,
                CellScratch &w, FoundPairs &mine) {
  // The search's constants in locals: the stores could otherwise alias them and force a
  // reload per candidate.
  const Box box = s.box;
  const Vec3 inverse = s.inverse;
  const double h = s.h, reach = s.reach, diameter = s.diameter;
  const double centre_reach2 = s.centre_reach2, prefilter_reach2 = s.prefilter_reach2;
  const double *__restrict x = s.p.x.data(), *__restrict y = s.p.y.data(),
                           *__restrict z = s.p.z.data();
  const double *__restrict ex = s.p.ex.data(), *__restrict ey = s.p.ey.data(),
                           *__restrict ez = s.p.ez.data();
  // Body i's centre and axis as scalars: a Vec3 kept in memory would be loaded whole in the
  // loop, which then does not vectorise.
  const double xix = s.p.x[i], xiy = s.p.y[i], xiz = s.p.z[i];
  const double eix = s.p.ex[i], eiy = s.p.ey[i], eiz = s.p.ez[i];
  if (w.distance.size() < kept) w.distance.resize(kept), w.within.resize(kept);
  double *__restrict distance = w.distance.data();
  std::uint64_t *__restrict within = w.within.data();
#pragma GCC ivdep  // (omp simd would keep rij in memory per lane, and not vectorise)
  for (std::uint32_t k = 0; k < kept; ++k) {
    const std::uint32_t j = near[k];
    const Vec3 rij = box.minimum_image({x[j] - xix, y[j] - xiy, z[j] - xiz}, inverse);
    const Vec3 ei{eix, eiy, eiz};
    bool apart = !(norm2(rij) < centre_reach2);
    double d = 0.0;
    if constexpr (Rods) {
      const Vec3 ej{ex[j], ey[j], ez[j]};
      // Cheap lower bound: with n the unit vector along r's part perpendicular to e_i, every
      // point pair of the two segments is at least |r_perp| - h |e_j . n| apart (squared,
      // without a root; the margin keeps rounding from dropping a pair inside the reach).
      const Vec3 rperp = rij - dot(rij, ei) * ei;
      const double rp2 = norm2(rperp);
      const double lower = rp2 - h * std::fabs(dot(ej, rperp));  // bound x |r_perp|
      apart = apart | ((lower > 0.0) & (lower * lower > prefilter_reach2 * rp2));
      d = std::sqrt(segment_closest_inline(rij, ei, h, ej, h).dist2);
    } else {  // the centres' distance, segment_closest's bits (its gap is -rij when h = 0)
      d = std::sqrt(norm2(rij));
    }
    distance[k] = d;
    within[k] = !apart & (d < reach);
  }
  ListedPair *__restrict out = mine.room(kept);  // listed without a branch
  std::size_t listed = 0;
  for (std::uint32_t k = 0; k < kept; ++k) {
    out[listed] = {i, near[k], slack_below(distance[k] - diameter - kDistanceSafetyMargin), 0.0f};
    listed += within[k];
  }
  mine.count += listed;
}

// The position after the last owned body among the candidates (0 if none): a shadow at or
// past it has no pair to look for.
std::uint32_t owned_end(const PairSearch &s, const CellScratch &w) {
  auto q = static_cast<std::uint32_t>(w.cand.size());
  while (q > 0 && w.cand[q - 1] >= s.owned) --q;
  return q;
}

// The pairs of cell c's bodies with the later candidates, appended to `mine`; no pair of two
// shadows.
void search_cell(const PairSearch &s, int c, CellScratch &w, FoundPairs &mine) {
  const std::uint32_t own = gather_cell(s, c, w);
  const std::uint32_t ncand = static_cast<std::uint32_t>(w.cand.size());
  const std::uint32_t last = owned_end(s, w);
  for (std::uint32_t a = 0; a < own; ++a) {
    if (w.cand[a] >= s.owned && a + 1 >= last) continue;  // a shadow, only shadows after it
    if (s.unique_images && !s.rods) {
      list_spheres(s, w, a, mine);
      continue;
    }
    if (w.near.size() < ncand) w.near.resize(ncand);
    std::uint32_t kept = 0;
    if (s.unique_images) {
      kept = preselect_rods(s, w, a);
    } else {
      const std::uint32_t limit =
          w.cand[a] < s.owned ? std::numeric_limits<std::uint32_t>::max() : s.owned;
      for (std::uint32_t q = a + 1; q < ncand; ++q)
        if (w.cand[q] < limit) w.near[kept++] = w.cand[q];
    }
    if (s.rods)
      list_pairs<true>(s, w.cand[a], w.near.data(), kept, w, mine);
    else
      list_pairs<false>(s, w.cand[a], w.near.data(), kept, w, mine);
  }
}

// Every pair within reach, in cell order, into `pairs` (its storage reused). Threads take runs
// of kCellChunk cells as they come free (the cells near the window's start reach more later
// cells across the periodic wrap, so equal blocks of cells are unequal work), and the runs'
// pairs are concatenated in cell order. So the list comes out in cell order, which is body order,
// for any thread count, and the per-step passes, split in blocks of bodies (team_block), give each
// thread mostly its own pairs, with the bodies' motion bounds in its cache.
constexpr int kCellChunk = 8;

}  // namespace

void find_pairs(const Particles &p, const Box &box, const Shape &shape, const CellList &cl,
                double skin, std::size_t owned, std::vector<ListedPair> &pairs) {
  const PairSearch s(p, box, shape, cl, skin, owned);
  // The threads' pairs, their storage kept from build to build (grown from nothing, a list of
  // 10^5 pairs was copied over a dozen times), reached by the team through a reference.
  thread_local std::vector<FoundPairs> storage;
  std::vector<FoundPairs> &found = storage;
  found.resize(static_cast<std::size_t>(omp_get_max_threads()));
  for (FoundPairs &f : found) f.count = 0;  // (also those of threads a smaller team leaves out)
  // Where each run of cells put its pairs: the thread, and the range in its storage.
  struct Placed {
    int thread;
    std::size_t begin, end;
  };
  const int cells = s.cl.cell_count();
  const int runs = (cells + kCellChunk - 1) / kCellChunk;
  thread_local std::vector<Placed> placed_storage;
  std::vector<Placed> &placed = placed_storage;
  placed.resize(static_cast<std::size_t>(runs));
#pragma omp parallel
  {
    const int tid = omp_get_thread_num();
    FoundPairs &mine = found[static_cast<std::size_t>(tid)];
    // Each thread's scratch, kept from build to build too (grown from nothing, its arrays were
    // allocated and zeroed again at every build).
    thread_local CellScratch scratch;
#pragma omp for schedule(dynamic, 1)
    for (int r = 0; r < runs; ++r) {
      const std::size_t begin = mine.count;
      for (int c = r * kCellChunk; c < std::min(cells, (r + 1) * kCellChunk); ++c) {
        // An empty cell has no pairs to start (in a gas, or the box beyond a rank's halo).
        if (s.cl.cell_start[c + 1] == s.cl.cell_start[c]) continue;
        search_cell(s, c, scratch, mine);
      }
      placed[static_cast<std::size_t>(r)] = {tid, begin, mine.count};
    }
  }
  pairs.clear();
  for (const Placed &at : placed) {
    const ListedPair *from = found[static_cast<std::size_t>(at.thread)].pairs.data();
    pairs.insert(pairs.end(), from + at.begin, from + at.end);
  }
}

}  // namespace hardrod
