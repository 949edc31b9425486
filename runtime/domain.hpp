// Domain decomposition: the periodic box cut into a 3D grid of subdomains, one per rank
// (rank = (cz * dy + cy) * dx + cx). A rank owns the bodies whose centres lie in its
// subdomain (checked at every neighbour-list rebuild, when bodies migrate) and holds
// shadow copies of every body within `halo` of it. Partners are the ranks whose
// subdomains lie within two halos: every rank that can share a body or a contact cluster.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/vec3.hpp"

namespace hardrod {

class Domain {
 public:
  Domain() = default;
  Domain(const Box &box, std::array<int, 3> grid, int rank, double halo);

  int rank() const { return rank_; }
  int ranks() const { return grid_[0] * grid_[1] * grid_[2]; }
  const std::array<int, 3> &grid() const { return grid_; }
  double halo() const { return halo_; }
  const std::vector<int> &partners() const { return partners_; }

  // Rank whose subdomain contains the (folded) centre p.
  int owner_of(const Vec3 &p) const;
  // True when p lies within `margin` of rank r's subdomain along every axis (periodic).
  bool near(const Vec3 &p, int r, double margin) const;
  std::array<double, 3> lower(int r) const;
  std::array<double, 3> upper(int r) const;
  std::string describe() const;

 private:
  std::array<int, 3> coords(int r) const;

  Box box_;
  std::array<int, 3> grid_{1, 1, 1};
  int rank_ = 0;
  double halo_ = 0.0;
  std::vector<int> partners_;
};

}  // namespace hardrod
