#include "runtime/domain.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

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

Domain::Domain(const Box &box, std::array<int, 3> grid, int rank, double shadow_reach,
               double partner_reach)
    : box_(box), grid_(grid), rank_(rank), shadow_reach_(shadow_reach) {
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
}

std::array<int, 3> Domain::coords(int r) const {
  return {r % grid_[0], (r / grid_[0]) % grid_[1], r / (grid_[0] * grid_[1])};
}

std::array<double, 3> Domain::lower(int r) const {
  const auto c = coords(r);
  std::array<double, 3> out{};
  for (int a = 0; a < 3; ++a) out[a] = side_of(box_, a) * c[a] / grid_[a];
  return out;
}

std::array<double, 3> Domain::upper(int r) const {
  const auto c = coords(r);
  std::array<double, 3> out{};
  for (int a = 0; a < 3; ++a) out[a] = side_of(box_, a) * (c[a] + 1) / grid_[a];
  return out;
}

int Domain::owner_of(const Vec3 &p) const {
  const Vec3 folded = box_.wrap(p);  // centres are not folded while the bodies move
  const double x[3] = {folded.x, folded.y, folded.z};
  int c[3];
  for (int a = 0; a < 3; ++a) {
    // Same rule as lower()/upper(): cell k covers [side k / g, side (k+1) / g).
    const double side = side_of(box_, a);
    int k = static_cast<int>(std::floor(x[a] / side * grid_[a]));
    k = std::clamp(k, 0, grid_[a] - 1);
    if (x[a] < side * k / grid_[a] && k > 0) --k;
    if (k + 1 < grid_[a] && x[a] >= side * (k + 1) / grid_[a]) ++k;
    c[a] = k;
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

std::string Domain::describe() const {
  return fmt::format(
      "{} x {} x {} ranks, subdomain {:.3f} x {:.3f} x {:.3f}, shadows within {:.3f} of the "
      "subdomain (axis segment), {} partners",
      grid_[0], grid_[1], grid_[2], box_.length.x / grid_[0], box_.length.y / grid_[1],
      box_.length.z / grid_[2], shadow_reach_, partners_.size());
}

}  // namespace hardrod
