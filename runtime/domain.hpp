// Domain decomposition: the periodic box cut into a 3D grid of subdomains, one per rank
// (rank = (cz * dy + cy) * dx + cx). Along each axis the grid's cuts are shared by a whole
// slab of ranks (a staggered-free "shifted grid"): uniform at start, moved by the load
// balancer (runtime/balance.hpp), so the partners stay grid neighbours. A rank owns the bodies
// whose centres lie in its subdomain (checked at every neighbour-list rebuild, when bodies migrate)
// and holds shadow copies of every body whose axis segment comes within `shadow_reach` of it.
// Partners are the ranks whose subdomains lie within `partner_reach`: every rank that can
// share a body or a contact cluster.
#pragma once

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/vec3.hpp"

namespace hardrod {

// Cut positions per axis: grid[a] + 1 increasing values from 0 to the box side.
using Cuts = std::array<std::vector<double>, 3>;

class Domain {
 public:
  Domain() = default;
  // `cuts` empty: uniform (side k / grid[a]).
  Domain(const Box &box, std::array<int, 3> grid, int rank, double shadow_reach,
         double partner_reach, Cuts cuts = {});
  static Cuts uniform_cuts(const Box &box, std::array<int, 3> grid);
  // The slab of one axis's cuts that holds the folded coordinate x: k with
  // cuts[k] <= x < cuts[k + 1] (the first and last slabs also take what rounds past the ends).
  static int slab(const std::vector<double> &cuts, double x);

  int rank() const { return rank_; }
  int ranks() const { return grid_[0] * grid_[1] * grid_[2]; }
  const std::array<int, 3> &grid() const { return grid_; }
  double shadow_reach() const { return shadow_reach_; }
  double partner_reach() const { return partner_reach_; }
  const Cuts &cuts() const { return cuts_; }
  const Box &box() const { return box_; }
  const std::vector<int> &partners() const { return partners_; }
  // Position of rank r in partners() (sorted), where messages to it go; partners().size()
  // or a rank other than r there when r is not a partner.
  std::size_t partner_slot(int r) const {
    return static_cast<std::size_t>(std::lower_bound(partners_.begin(), partners_.end(), r) -
                                    partners_.begin());
  }

  // Rank whose subdomain contains the (folded) centre p.
  int owner_of(const Vec3 &p) const;
  // Grid coordinates of rank r (rank = (cz * dy + cy) * dx + cx).
  std::array<int, 3> coords(int r) const;
  // True when the segment centre +- h e comes closer than shadow_reach() to rank r's
  // subdomain (periodic). Uses the Euclidean norm of the per-axis gaps between the
  // segment's projection and the subdomain, a lower bound of the true distance, so the
  // test never misses a body that can touch.
  bool reaches(const Vec3 &centre, const Vec3 &axis, double h, int r) const;
  // The partners that reaches() accepts for this segment, appended to `out` in partners()
  // order; reaches() runs only on those in a slab near the segment along every axis.
  void reached_partners(const Vec3 &centre, const Vec3 &axis, double h,
                        std::vector<int> &out) const;
  std::array<double, 3> lower(int r) const;
  std::array<double, 3> upper(int r) const;
  std::string describe() const;

 private:
  Box box_;
  std::array<int, 3> grid_{1, 1, 1};
  int rank_ = 0;
  double shadow_reach_ = 0.0;
  double partner_reach_ = 0.0;
  Cuts cuts_;
  std::vector<int> partners_;
  // Along each axis, the slabs the partners lie in; by partner, the position of its slab in
  // those (reached_partners' filter).
  std::array<std::vector<int>, 3> partner_slabs_;
  std::vector<std::array<int, 3>> partner_slab_at_;
};

}  // namespace hardrod
