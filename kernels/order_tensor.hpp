// Nematic order: the order tensor Q = (1/N) sum_i (3/2 e_i e_i^T - 1/2 I), its largest
// eigenvalue S and eigenvector (the director), and the distribution of |e . n| (docs/physics.md
// section 5). Reads Particles::ex, ey, ez of bodies [0, count); writes nothing.
// Threading: OpenMP, static schedule, per-thread partial sums merged in thread order; the
// sums are exact fixed-point (ExactSum) and the histogram integer, so the result has the
// same bits for any thread count, rank count or body order (docs/physics.md section 7).
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "kernels/exact_sum.hpp"
#include "kernels/particles.hpp"
#include "kernels/vec3.hpp"

namespace hardrod {

// Sums of e_a e_b over bodies. Mergeable across threads and ranks (raw() of each sum).
struct AxisMoments {
  ExactSum xx, xy, xz, yy, yz, zz;
  long long count = 0;
  AxisMoments &operator+=(const AxisMoments &o);
};

AxisMoments axis_moments(const Particles &p, std::size_t count);

struct OrderParameter {
  double S = 0.0;                       // largest eigenvalue of Q
  Vec3 director;                        // its unit eigenvector, largest-|component| positive
  std::array<double, 9> Q{};            // row-major
  std::array<double, 3> eigenvalues{};  // ascending
};

// Q from the summed moments, diagonalised with Eigen's SelfAdjointEigenSolver. When the two
// largest eigenvalues coincide (e.g. axes spread uniformly in a plane) the director is any
// unit vector in their eigenspace. No bodies or poisoned sums (a non-finite axis): every
// field NaN, for the caller's NaN check to stop on.
OrderParameter order_parameter(const AxisMoments &m);

// Histogram of cos(theta) = |e . n| over [0, 1] in equal-width bins. A non-finite cos(theta)
// is counted as invalid; the bin index is clamped so |e . n| = 1 + ulp lands in the last bin.
struct AngularCounts {
  std::vector<long long> counts;  // per bin
  long long total = 0;            // bodies seen, including invalid ones
  long long invalid = 0;
  AngularCounts &operator+=(const AngularCounts &o);  // same number of bins
  // counts * bins / total: the isotropic distribution (uniform in cos theta) gives 1 in
  // every bin. NaN in every bin if there is an invalid body or none at all.
  std::vector<double> normalised() const;
};

AngularCounts angular_counts(const Particles &p, std::size_t count, const Vec3 &director, int bins);

// Single-rank convenience: angular_counts(...).normalised().
std::vector<double> angular_histogram(const Particles &p, std::size_t count, const Vec3 &director,
                                      int bins);

}  // namespace hardrod
