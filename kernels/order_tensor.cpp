// Order tensor, director and angular distribution of the rod axes (docs/physics.md section 5).
// Each thread sums its static share of bodies into a private AxisMoments / AngularCounts;
// the partials are merged in thread order after the parallel region. Exact (integer) sums
// make that merge order irrelevant to the bits; it is fixed anyway, by habit.
#include "kernels/order_tensor.hpp"

#include <omp.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace hardrod {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

void require_count(const Particles &p, std::size_t count, const char *who) {
  if (count > p.size())
    throw std::invalid_argument(std::string(who) + ": count " + std::to_string(count) +
                                " exceeds the " + std::to_string(p.size()) + " bodies held");
}

OrderParameter undefined_order_parameter() {
  OrderParameter op;
  op.S = kNaN;
  op.director = {kNaN, kNaN, kNaN};
  op.Q.fill(kNaN);
  op.eigenvalues.fill(kNaN);
  return op;
}

}  // namespace

AxisMoments &AxisMoments::operator+=(const AxisMoments &o) {
  xx += o.xx;
  xy += o.xy;
  xz += o.xz;
  yy += o.yy;
  yz += o.yz;
  zz += o.zz;
  count += o.count;
  return *this;
}

AxisMoments axis_moments(const Particles &p, std::size_t count) {
  require_count(p, count, "axis_moments");
  const double *ex = p.ex.data();
  const double *ey = p.ey.data();
  const double *ez = p.ez.data();
  const auto n = static_cast<std::ptrdiff_t>(count);
  std::vector<AxisMoments> partial(static_cast<std::size_t>(omp_get_max_threads()));
#pragma omp parallel num_threads(static_cast <int>(partial.size()))
  {
    AxisMoments mine;  // on this thread's stack: no false sharing while summing
#pragma omp for schedule(static)
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      mine.xx.add(ex[i] * ex[i]);
      mine.xy.add(ex[i] * ey[i]);
      mine.xz.add(ex[i] * ez[i]);
      mine.yy.add(ey[i] * ey[i]);
      mine.yz.add(ey[i] * ez[i]);
      mine.zz.add(ez[i] * ez[i]);
    }
    partial[static_cast<std::size_t>(omp_get_thread_num())] = mine;
  }
  AxisMoments total;
  for (const AxisMoments &m : partial) total += m;
  total.count = static_cast<long long>(count);
  return total;
}

OrderParameter order_parameter(const AxisMoments &m) {
  if (m.count <= 0) return undefined_order_parameter();
  const double n = static_cast<double>(m.count);
  const std::array<double, 6> moment = {m.xx.value(), m.xy.value(), m.xz.value(),
                                        m.yy.value(), m.yz.value(), m.zz.value()};
  for (double v : moment)
    if (!std::isfinite(v)) return undefined_order_parameter();

  OrderParameter op;
  const double qxx = 1.5 * (moment[0] / n) - 0.5;
  const double qxy = 1.5 * (moment[1] / n);
  const double qxz = 1.5 * (moment[2] / n);
  const double qyy = 1.5 * (moment[3] / n) - 0.5;
  const double qyz = 1.5 * (moment[4] / n);
  const double qzz = 1.5 * (moment[5] / n) - 0.5;
  op.Q = {qxx, qxy, qxz, qxy, qyy, qyz, qxz, qyz, qzz};

  const Eigen::Matrix3d q =
      Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(op.Q.data());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(q);
  if (solver.info() != Eigen::Success) return undefined_order_parameter();
  for (int k = 0; k < 3; ++k) op.eigenvalues[static_cast<std::size_t>(k)] = solver.eigenvalues()(k);
  op.S = op.eigenvalues[2];

  // An eigenvector's sign is arbitrary; fix it so the largest component (first on ties) is
  // positive, which makes the director comparable between samples and runs.
  Eigen::Vector3d axis = solver.eigenvectors().col(2);
  int largest = 0;
  for (int k = 1; k < 3; ++k)
    if (std::fabs(axis(k)) > std::fabs(axis(largest))) largest = k;
  if (axis(largest) < 0.0) axis = -axis;
  op.director = {axis(0), axis(1), axis(2)};
  return op;
}

AngularCounts &AngularCounts::operator+=(const AngularCounts &o) {
  if (o.counts.size() != counts.size())
    throw std::invalid_argument("AngularCounts: merging histograms with different bin counts");
  for (std::size_t b = 0; b < counts.size(); ++b) counts[b] += o.counts[b];
  total += o.total;
  invalid += o.invalid;
  return *this;
}

std::vector<double> AngularCounts::normalised() const {
  std::vector<double> density(counts.size(), kNaN);
  if (total <= 0 || invalid > 0) return density;
  const double scale = static_cast<double>(counts.size()) / static_cast<double>(total);
  for (std::size_t b = 0; b < counts.size(); ++b)
    density[b] = static_cast<double>(counts[b]) * scale;
  return density;
}

AngularCounts angular_counts(const Particles &p, std::size_t count, const Vec3 &director,
                             int bins) {
  require_count(p, count, "angular_counts");
  if (bins <= 0)
    throw std::invalid_argument("angular_counts: bins must be positive, got " +
                                std::to_string(bins));
  const double *ex = p.ex.data();
  const double *ey = p.ey.data();
  const double *ez = p.ez.data();
  const auto n = static_cast<std::ptrdiff_t>(count);
  const AngularCounts empty{std::vector<long long>(static_cast<std::size_t>(bins), 0), 0, 0};
  std::vector<AngularCounts> partial(static_cast<std::size_t>(omp_get_max_threads()), empty);
#pragma omp parallel num_threads(static_cast <int>(partial.size()))
  {
    AngularCounts mine = empty;
#pragma omp for schedule(static)
    for (std::ptrdiff_t i = 0; i < n; ++i) {
      const double cos_theta =
          std::fabs(ex[i] * director.x + ey[i] * director.y + ez[i] * director.z);
      if (!std::isfinite(cos_theta)) {
        ++mine.invalid;
        continue;
      }
      const double scaled = std::fmin(cos_theta * bins, static_cast<double>(bins - 1));
      ++mine.counts[static_cast<std::size_t>(scaled)];
    }
    partial[static_cast<std::size_t>(omp_get_thread_num())] = std::move(mine);
  }
  AngularCounts total = empty;
  for (const AngularCounts &c : partial) total += c;
  total.total = static_cast<long long>(count);
  return total;
}

std::vector<double> angular_histogram(const Particles &p, std::size_t count, const Vec3 &director,
                                      int bins) {
  return angular_counts(p, count, director, bins).normalised();
}

}  // namespace hardrod
