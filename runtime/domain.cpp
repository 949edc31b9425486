#include "runtime/domain.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace hardrod {

namespace {

// Distance from x to the arc [lo, hi) on a circle of circumference side.
double arc_distance(double x, double lo, double hi, double side) {
  const double shifted = lo + Box::wrap(x - lo, side);
  if (shifted < hi) return 0.0;
  return std::min(shifted - hi, lo + side - shifted);
}

// Distance between two arcs on the circle (0 if they overlap).
double arcs_distance(double lo1, double hi1, double lo2, double hi2, double side) {
  return std::min({arc_distance(lo2, lo1, hi1, side), arc_distance(hi2, lo1, hi1, side),
                   arc_distance(lo1, lo2, hi2, side), arc_distance(hi1, lo2, hi2, side)});
}

double side_of(const Box &box, int a) {
  return a == 0 ? box.length.x : (a == 1 ? box.length.y : box.length.z);
}

}  // namespace

Cuts Domain::uniform_cuts(const Box &box, std::array<int, 3> grid) {
  Cuts cuts;
  for (int a = 0; a < 3; ++a)
    for (int k = 0; k <= grid[a]; ++k)  // exactly the side at the end (side g / g may not be)
      cuts[a].push_back(k == grid[a] ? side_of(box, a) : side_of(box, a) * k / grid[a]);
  return cuts;
}

int Domain::slab(const std::vector<double> &cuts, double x) {
  const auto above = std::upper_bound(cuts.begin() + 1, cuts.end() - 1, x);
  return static_cast<int>(above - cuts.begin()) - 1;
}

Domain::Domain(const Box &box, std::array<int, 3> grid, int rank, double shadow_reach,
               double partner_reach, Cuts cuts)
    : box_(box),
      grid_(grid),
      rank_(rank),
      shadow_reach_(shadow_reach),
      partner_reach_(partner_reach),
      cuts_(cuts[0].empty() ? uniform_cuts(box, grid) : std::move(cuts)) {
  for (int a = 0; a < 3; ++a) {
    const auto &c = cuts_[a];
    bool ok = c.size() == static_cast<std::size_t>(grid_[a]) + 1 && c.front() == 0.0 &&
              c.back() == side_of(box_, a);
    for (std::size_t k = 1; ok && k < c.size(); ++k) ok = c[k] > c[k - 1];
    if (!ok)
      throw std::invalid_argument(fmt::format(
          "Domain: the cuts along axis {} must rise from 0 to the box side {} in {} steps, got "
          "[{}]",
          a, side_of(box_, a), grid_[a], fmt::join(c, ", ")));
  }
  const auto lo = lower(rank_), hi = upper(rank_);
  for (int r = 0; r < ranks(); ++r) {
    if (r == rank_) continue;
    const auto rlo = lower(r), rhi = upper(r);
    bool close = true;
    for (int a = 0; a < 3; ++a)
      close =
          close && arcs_distance(lo[a], hi[a], rlo[a], rhi[a], side_of(box_, a)) < partner_reach;
    if (close) partners_.push_back(r);
  }
  for (int a = 0; a < 3; ++a) {
    std::vector<int> &slabs = partner_slabs_[static_cast<std::size_t>(a)];
    for (int r : partners_) slabs.push_back(coords(r)[static_cast<std::size_t>(a)]);
    std::sort(slabs.begin(), slabs.end());
    slabs.erase(std::unique(slabs.begin(), slabs.end()), slabs.end());
  }
  for (int r : partners_) {
    std::array<int, 3> at{};
    for (std::size_t a = 0; a < 3; ++a) {
      const std::vector<int> &slabs = partner_slabs_[a];
      at[a] = static_cast<int>(std::lower_bound(slabs.begin(), slabs.end(), coords(r)[a]) -
                               slabs.begin());
    }
    partner_slab_at_.push_back(at);
  }
}

std::array<int, 3> Domain::coords(int r) const {
  return {r % grid_[0], (r / grid_[0]) % grid_[1], r / (grid_[0] * grid_[1])};
}

std::array<double, 3> Domain::lower(int r) const {
  const auto c = coords(r);
  std::array<double, 3> out{};
  for (int a = 0; a < 3; ++a) out[a] = cuts_[a][static_cast<std::size_t>(c[a])];
  return out;
}

std::array<double, 3> Domain::upper(int r) const {
  const auto c = coords(r);
  std::array<double, 3> out{};
  for (int a = 0; a < 3; ++a) out[a] = cuts_[a][static_cast<std::size_t>(c[a]) + 1];
  return out;
}

int Domain::owner_of(const Vec3 &p) const {
  const Vec3 folded = box_.wrap(p);  // centres are not folded while the bodies move
  const double x[3] = {folded.x, folded.y, folded.z};
  int c[3];
  for (int a = 0; a < 3; ++a) {
    c[a] = slab(cuts_[a], x[a]);  // the rule of lower()/upper()
  }
  return (c[2] * grid_[1] + c[1]) * grid_[0] + c[0];
}

bool Domain::reaches(const Vec3 &centre, const Vec3 &axis, double h, int r) const {
  const double c[3] = {centre.x, centre.y, centre.z};
  const double e[3] = {axis.x, axis.y, axis.z};
  const auto lo = lower(r), hi = upper(r);
  double gap2 = 0.0;
  for (int a = 0; a < 3; ++a) {
    // Gap between the segment's projection [c - |e| h, c + |e| h] and [lo, hi).
    const double extent = std::fabs(e[a]) * h;
    const double gap = std::max(0.0, arc_distance(c[a], lo[a], hi[a], side_of(box_, a)) - extent);
    gap2 += gap * gap;
  }
  return gap2 < shadow_reach_ * shadow_reach_;
}

// A partner that reaches() accepts is, along every axis, within shadow_reach plus the
// segment's extent of the centre: its gap there is at most the Euclidean norm of the gaps. The
// slabs farther than that (by a margin over the rounding, on the same arc distances) are
// passed over; reaches() decides for the rest, so the holders are the same as testing every
// partner.
void Domain::reached_partners(const Vec3 &centre, const Vec3 &axis, double h,
                              std::vector<int> &out) const {
  const double c[3] = {centre.x, centre.y, centre.z};
  const double e[3] = {axis.x, axis.y, axis.z};
  constexpr std::size_t kBits = 64;
  std::array<std::uint64_t, 3> near{};
  for (std::size_t a = 0; a < 3; ++a) {
    const std::vector<int> &slabs = partner_slabs_[a];
    const double side = side_of(box_, static_cast<int>(a));
    const double limit = shadow_reach_ + std::fabs(e[a]) * h;
    const double within = limit + 1e-9 * (limit + side);
    for (std::size_t k = 0; k < slabs.size() && k < kBits; ++k) {
      const auto s = static_cast<std::size_t>(slabs[k]);
      if (arc_distance(c[a], cuts_[a][s], cuts_[a][s + 1], side) < within)
        near[a] |= std::uint64_t{1} << k;
    }
  }
  const auto is_near = [&](std::size_t a, int k) {
    return static_cast<std::size_t>(k) >= kBits || ((near[a] >> k) & 1U) != 0;
  };
  for (std::size_t k = 0; k < partners_.size(); ++k) {
    const std::array<int, 3> &at = partner_slab_at_[k];
    if (!is_near(0, at[0]) || !is_near(1, at[1]) || !is_near(2, at[2])) continue;
    if (reaches(centre, axis, h, partners_[k])) out.push_back(partners_[k]);
  }
}

std::string Domain::describe() const {
  std::string widths;
  for (int a = 0; a < 3; ++a) {
    double lo = side_of(box_, a), hi = 0.0;
    for (std::size_t k = 1; k < cuts_[a].size(); ++k) {
      lo = std::min(lo, cuts_[a][k] - cuts_[a][k - 1]);
      hi = std::max(hi, cuts_[a][k] - cuts_[a][k - 1]);
    }
    widths += (a ? " x " : "") + (hi - lo > 1e-9 * hi ? fmt::format("{:.3f}-{:.3f}", lo, hi)
                                                      : fmt::format("{:.3f}", hi));
  }
  return fmt::format(
      "{} x {} x {} ranks, subdomain {}, shadows within {:.3f} of the subdomain (axis "
      "segment), {} partners",
      grid_[0], grid_[1], grid_[2], widths, shadow_reach_, partners_.size());
}

}  // namespace hardrod
