// Observables of the whole system, collective over ranks: the order parameter, the kinetic
// energy, the Fourier order tensor, the angular distribution, and the running totals of
// the step (contacts, collisions, virial, solver) since the last sample. Exact sums make
// them the same bits for any rank and thread count, except where noted. Not here: what a
// run does with them (runtime/run_loop.cpp).
#include <fmt/format.h>

#include <algorithm>
#include <numeric>

#include "kernels/thermostat.hpp"
#include "runtime/system.hpp"

namespace hardrod {

namespace {

// Global axis moments from the first six of a rank-summed list (xx, xy, xz, yy, yz, zz).
AxisMoments moments_from(const std::vector<ExactSum> &sums, long long n) {
  AxisMoments m;
  m.xx = sums[0];
  m.xy = sums[1];
  m.xz = sums[2];
  m.yy = sums[3];
  m.yz = sums[4];
  m.zz = sums[5];
  m.count = n;
  return m;
}

}  // namespace

IntervalTotals System::pending_interval() {
  IntervalTotals t = interval_;
  if (comm_.size() == 1) return t;
  const auto sums = comm_.sum("checkpoint", {t.virial, t.solver_energy_change});
  t.virial = sums[0];
  t.solver_energy_change = sums[1];
  sum_counts_over_ranks(t, "checkpoint");  // steps: every rank counts every step already
  return t;
}

void System::restore_interval(const IntervalTotals &totals) {
  interval_ = comm_.is_root() ? totals : IntervalTotals{};
  interval_.steps = totals.steps;  // every rank counts every step
}

IntervalTotals System::take_interval() {
  IntervalTotals out = interval_;
  interval_ = IntervalTotals{};
  return out;
}

double System::kinetic_energy() {
  const KineticEnergy local = hardrod::kinetic_energy(particles_, owned_, scene_.shape);
  const auto sums = comm_.sum("kinetic_energy", {local.translational, local.rotational});
  ExactSum total = sums[0];
  total += sums[1];
  return total.value();
}

Observation System::observe() {
  Observation o;
  o.step = step_;
  const IntervalTotals t = take_interval();
  const AxisMoments m = axis_moments(particles_, owned_);
  const KineticEnergy ke = hardrod::kinetic_energy(particles_, owned_, scene_.shape);
  const auto sums = comm_.sum("observe", {m.xx, m.xy, m.xz, m.yy, m.yz, m.zz, ke.translational,
                                          ke.rotational, t.virial, t.solver_energy_change});
  const OrderParameter q = order_parameter(moments_from(sums, scene_.n));
  o.order_parameter = q.S;
  o.director = q.director;
  ExactSum e = sums[6];
  e += sums[7];
  o.kinetic_energy = e.value();
  const double dof =
      static_cast<double>(scene_.shape.degrees_of_freedom()) * static_cast<double>(scene_.n) - 3.0;
  o.temperature = 2.0 * o.kinetic_energy / dof;
  o.totals = t;
  o.totals.virial = sums[8];
  o.totals.solver_energy_change = sums[9];
  sum_counts_over_ranks(o.totals, "observe");
  return o;
}

void System::sum_counts_over_ranks(IntervalTotals &t, const char *name) {
  if (comm_.size() == 1) return;
  for (long long *v : {&t.collisions, &t.narrow_phase_tests, &t.contacts, &t.multi_contact_bodies,
                       &t.clusters, &t.solver_unconverged})
    *v = comm_.sum(name, *v);
  const auto mx = comm_.max(name, {t.max_depth, static_cast<double>(t.solver_iterations_max)});
  t.max_depth = mx[0];
  t.solver_iterations_max = static_cast<long long>(mx[1]);
}

OrderParameter System::order() {
  const AxisMoments m = axis_moments(particles_, owned_);
  return order_parameter(
      moments_from(comm_.sum("observe", {m.xx, m.xy, m.xz, m.yy, m.yz, m.zz}), scene_.n));
}

FourierOrderTensor System::fourier_order(int kmax) {
  // Owned bodies in id order: the sums then round the same way whatever order the pair-list
  // builds left them in, so a resumed run accumulates the same bits as an uninterrupted one.
  Particles sorted = particles_;
  sorted.resize(owned_);
  std::vector<std::uint32_t> by_id(owned_);
  std::iota(by_id.begin(), by_id.end(), 0u);
  std::sort(by_id.begin(), by_id.end(),
            [&](std::uint32_t a, std::uint32_t b) { return sorted.id[a] < sorted.id[b]; });
  sorted.permute(by_id);
  FourierOrderTensor q = fourier_order_tensor(sorted, owned_, scene_.box, kmax);
  if (comm_.size() == 1) return q;
  // Ranks' partial sums travel as doubles and are added at rank 0 in rank order.
  std::vector<char> mine;
  for (const auto &mode : q.sums)
    for (const auto &c : mode) {
      pack(mine, c.real());
      pack(mine, c.imag());
    }
  for (double f : q.fourth_moments) pack(mine, f);
  const std::vector<char> all = comm_.gather("fourier", mine);
  if (!comm_.is_root()) return q;
  q.bodies = scene_.n;
  for (auto &mode : q.sums) mode.fill({0.0, 0.0});
  q.fourth_moments.fill(0.0);
  for (std::size_t off = 0; off < all.size();) {
    for (auto &mode : q.sums)
      for (auto &c : mode) {
        const double re = unpack<double>(all, off);
        const double im = unpack<double>(all, off);
        c += std::complex<double>(re, im);
      }
    for (double &f : q.fourth_moments) f += unpack<double>(all, off);
  }
  return q;
}

AngularCounts System::angular_distribution(const Vec3 &director, int bins) {
  AngularCounts local = angular_counts(particles_, owned_, director, bins);
  if (comm_.size() == 1) return local;
  AngularCounts global = local;
  for (auto &c : global.counts) c = comm_.sum("observe", c);
  global.total = comm_.sum("observe", local.total);
  global.invalid = comm_.sum("observe", local.invalid);
  return global;
}

}  // namespace hardrod
