// A neighbour list extended body by body (list_extension.hpp).
#include "kernels/exact/list_extension.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include "kernels/segment_geometry.hpp"

namespace hardrod {
namespace {

// The window index of box coordinate g along an axis, or -1 outside the window (no bodies).
int window_coordinate(const CellList &cl, int axis, int g) {
  const int n = cl.cells[axis];
  const int w = ((g - cl.origin[axis]) % n + n) % n;
  return w < cl.extent[axis] ? w : -1;
}

// An extension's storage, kept from call to call (a call extends a few bodies).
struct ExtensionScratch {
  std::vector<std::uint32_t> due, mark, found, ends, nearby;
  std::vector<std::uint8_t> flag;
  std::array<std::vector<int>, 3> along;
  std::uint32_t tag = 0;
};

class Extension {
 public:
  Extension(NeighborList &list, const ListExtension &ext, const Box &box, const Shape &shape,
            ExtensionScratch &scratch)
      : list_(list),
        ext_(ext),
        box_(box),
        inverse_(box.inverse_length()),
        shape_(shape),
        mark_(scratch.mark),
        found_(scratch.found),
        ends_(scratch.ends),
        nearby_(scratch.nearby),
        along_(scratch.along),
        tag_(scratch.tag) {}

  // Body a's reach extended to `reach` (the others' reaches as they are, the largest
  // `largest`): its new partners listed, with their ends in the by-body index.
  void extend(std::uint32_t a, double reach, double largest) {
    mark_partners(a);
    found_.clear();
    const double half = 0.5 * list_.skin, D = shape_.diameter, h = shape_.half_length();
    const auto &at = ext_.built;
    const Vec3 xa{at.x[a], at.y[a], at.z[a]};
    const Vec3 ea = h > 0.0 ? Vec3{at.ex[a], at.ey[a], at.ez[a]} : Vec3{};
    gather_nearby(a, shape_.length + D + reach + largest);
    for (const std::uint32_t b : nearby_) {
      if (b == a || mark_[b] == tag_) continue;
      const double limit = D + reach + (half + ext_.extra_reach[b]) + kDistanceSafetyMargin;
      const Vec3 r = box_.minimum_image(Vec3{at.x[b], at.y[b], at.z[b]} - xa, inverse_);
      const double centre2 = norm2(r);
      if (!(centre2 < (shape_.length + limit) * (shape_.length + limit))) continue;
      const double d2 =
          h > 0.0 ? segment_closest_inline(r, ea, h, {at.ex[b], at.ey[b], at.ez[b]}, h).dist2
                  : centre2;
      if (!(std::sqrt(d2) < limit)) continue;
      found_.push_back(b);
    }
    list_pairs(a);
  }

 private:
  // Marks body a's listed partners (tag_ new for each body).
  void mark_partners(std::uint32_t a) {
    if (mark_.size() != list_.active) mark_.assign(list_.active, 0);
    if (++tag_ == 0) {
      std::fill(mark_.begin(), mark_.end(), 0);
      tag_ = 1;
    }
    for (std::uint32_t q = list_.pairs_start[a]; q < list_.pairs_end[a]; ++q)
      mark_[list_.pair_partner[q]] = tag_;
  }

  // The bodies of the build's cells within `distance` of body a's cell (one rank: a cell's
  // bodies are one index range, cells.order the identity).
  void gather_nearby(std::uint32_t a, double distance) {
    const CellList &cl = list_.cells;
    const auto &at = ext_.built;
    const double centre[3] = {at.x[a], at.y[a], at.z[a]};
    const double side[3] = {box_.length.x, box_.length.y, box_.length.z};
    for (int k = 0; k < 3; ++k) {
      std::vector<int> &along = along_[k];
      along.clear();
      // As build_cell_list bins (wrap / side * cells), over the centre's reach (and 1e-6 for
      // the rounding at a cell's edge).
      const int n = cl.cells[k];
      const double c = Box::wrap(centre[k], side[k]), reach = distance + 1e-6;
      const int first = static_cast<int>(std::floor((c - reach) / side[k] * n));
      const int last = static_cast<int>(std::floor((c + reach) / side[k] * n));
      for (int g = first; g <= std::min(last, first + n - 1); ++g) {
        const int w = window_coordinate(cl, k, ((g % n) + n) % n);
        if (w >= 0) along.push_back(w);
      }
    }
    nearby_.clear();
    for (const int z : along_[2])
      for (const int y : along_[1])
        for (const int x : along_[0]) {
          const int cell = cl.cell_index(x, y, z);
          for (std::uint32_t q = cl.cell_start[cell]; q < cl.cell_start[cell + 1]; ++q)
            nearby_.push_back(cl.order[q]);
        }
  }

  // The pairs of body a with found_, due at once, and their ends indexed.
  void list_pairs(std::uint32_t a) {
    ends_.clear();
    for (const std::uint32_t b : found_) {
      const auto k = static_cast<std::uint32_t>(list_.pairs.size());
      ListedPair pair;
      pair.first = std::min(a, b);
      pair.second = std::max(a, b);
      pair.recheck_at = -std::numeric_limits<float>::infinity();
      list_.pairs.push_back(pair);
      ends_.push_back(k);
    }
    append_ends(a, ends_.data(), found_.data(), found_.size());
    for (std::size_t k = 0; k < found_.size(); ++k) append_ends(found_[k], &ends_[k], &a, 1);
  }

  // Body b's run of the index moved to its end (unless it is there), and `count` ends added.
  void append_ends(std::uint32_t b, const std::uint32_t *pair, const std::uint32_t *partner,
                   std::size_t count) {
    std::vector<std::uint32_t> &index = list_.pair_index, &partners = list_.pair_partner;
    if (list_.pairs_end[b] != index.size()) {
      const auto moved = static_cast<std::uint32_t>(index.size());
      for (std::uint32_t q = list_.pairs_start[b]; q < list_.pairs_end[b]; ++q) {
        const std::uint32_t at = index[q], other = partners[q];
        index.push_back(at);
        partners.push_back(other);
      }
      list_.pairs_start[b] = moved;
    }
    index.insert(index.end(), pair, pair + count);
    partners.insert(partners.end(), partner, partner + count);
    list_.pairs_end[b] = static_cast<std::uint32_t>(index.size());
  }

  NeighborList &list_;
  const ListExtension &ext_;
  const Box &box_;
  Vec3 inverse_;
  const Shape &shape_;
  std::vector<std::uint32_t> &mark_, &found_, &ends_, &nearby_;
  std::array<std::vector<int>, 3> &along_;
  std::uint32_t &tag_;
};

// The bodies of [0, n) within `lead` of their reach, into `due`: flagged in vector
// lanes, then listed eight flags at a time past the clear ones (a few in thousands are due).
void list_due(const NeighborList &list, const ListExtension &ext, const double *bound,
              std::size_t n, double lead, ExtensionScratch &scratch) {
  const double half = 0.5 * list.skin, *extra = ext.extra_reach.data();
  std::vector<std::uint8_t> &flag = scratch.flag;
  flag.resize(n + 8);
  std::fill(flag.begin() + static_cast<long>(n), flag.end(), 0);
  std::uint8_t *__restrict f = flag.data();
#pragma omp simd
  for (std::size_t b = 0; b < n; ++b) f[b] = !(bound[b] + lead < half + extra[b]);
  std::vector<std::uint32_t> &due = scratch.due;
  due.clear();
  for (std::size_t b = 0; b < n; b += 8) {
    std::uint64_t word = 0;
    std::memcpy(&word, f + b, sizeof word);
    if (word == 0) continue;
    for (std::size_t k = b; k < std::min(b + 8, n); ++k)
      if (f[k]) due.push_back(static_cast<std::uint32_t>(k));
  }
}

}  // namespace

void start_extension(ListExtension &ext, const NeighborList &list, const Particles &p,
                     std::size_t owned, const Shape &shape) {
  const bool keep = list.bodies == owned, axes = keep && !shape.is_sphere();
  const std::size_t n = list.active;
  const auto copy = [n](std::vector<double> &to, const std::vector<double> &from, bool kept) {
    to.assign(from.begin(), from.begin() + static_cast<long>(kept ? n : 0));
  };
  auto &b = ext.built;
  copy(b.x, p.x, keep), copy(b.y, p.y, keep), copy(b.z, p.z, keep);
  copy(b.ex, p.ex, axes), copy(b.ey, p.ey, axes), copy(b.ez, p.ez, axes);
  ext.extra_reach.assign(keep ? n : 0, 0.0);
  ext.largest_extra = 0.0;
  ext.extended = 0;
}

bool extend_neighbor_list(NeighborList &list, ListExtension &ext, const Particles &p,
                          const Box &box, const Shape &shape, double lead, long long budget) {
  const std::size_t n = list.active;
  if (n != list.bodies || list.cells.order.size() != n || list.pairs_end.size() != n ||
      ext.extra_reach.size() != n || ext.built.x.size() != n)
    return false;
  const double half = 0.5 * list.skin, *bound = p.motion_bound.data();
  thread_local ExtensionScratch scratch;
  list_due(list, ext, bound, n, lead, scratch);
  const std::vector<std::uint32_t> &due = scratch.due;
  const auto count = static_cast<long long>(due.size());
  if (count == 0) return true;
  if (ext.extended + count > budget) return false;
  // A body whose step alone takes half the skin, or whose bound passed twice the skin, is a
  // runaway, not the tail: the build takes it (and refuses such a step by name).
  const double *grow = p.grow.data();
  for (const std::uint32_t b : due)
    if (!(grow[b] + grow[b] < half) || !(bound[b] + lead < 2.0 * list.skin) ||
        list.cells.order[b] != b)
      return false;
  for (const std::uint32_t b : due) {
    double &e = ext.extra_reach[b];
    while (!(bound[b] + lead < half + e)) e += half;
    ext.largest_extra = std::max(ext.largest_extra, e);
  }
  Extension extension(list, ext, box, shape, scratch);
  const auto listed = static_cast<std::uint32_t>(list.pair_count());
  for (const std::uint32_t b : due)
    extension.extend(b, half + ext.extra_reach[b], half + ext.largest_extra);
  ext.extended += count;
  ext.extensions += count;
  list.watching = false;
  if (list.near.valid)  // the new pairs are due: near ones, after the others in list order
    for (auto k = listed; k < list.pair_count(); ++k) list.near.index.push_back(k);
  return true;
}

}  // namespace hardrod
