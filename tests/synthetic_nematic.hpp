// Synthetic nematics for the Frank-constant tests: rods whose director field has Gaussian
// splay, twist and bend modes of prescribed K1, K2, K3 (optionally correlated in time, as in a
// run) and a nematic axis distribution about it (docs/frank.md).
// Configurations are built so that the paper's model holds exactly in expectation:
// Qk_m3(k) = (3/2) S dn_m(k) + white noise, with S the measured order parameter (see
// SyntheticSampler). Fixed seeds, hand-written normal deviates: the same samples with every
// standard library.
#pragma once

#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <numbers>
#include <random>
#include <vector>

#include "kernels/fourier_order_tensor.hpp"
#include "kernels/frank_fit.hpp"
#include "kernels/order_tensor.hpp"

namespace hardrod::synthetic {

struct SyntheticNematic {
  double side = 57.0512;            // the paper's box
  std::size_t bodies = 18432;       // and body count (rho = 0.0993)
  Vec3 director{1.0, 0.12, -0.07};  // mean director n0, tilted off the lattice axes
  // kT = 0.5 halves the director fluctuations of kT = 1 (the K/kT ratio is what matters),
  // so |lambda dn| < 1/2, needed below, holds for all but ~1e-5 of the bodies.
  double K1 = 0.8, K2 = 0.4, K3 = 1.6, kT = 0.5;
  double noise = 0.3;  // molecular disorder: S ~ 0.77 at noise 0.3
  int kmax = 4;        // field modes and analysis: -kmax < k_a < kmax
  // Correlation of the director modes between consecutive samples of a run: tau_k = tau0 / E_k
  // samples (E_k = K k^2, the mode's stiffness); 0: independent samples.
  double tau0 = 0.0;
  // The mean director's random walk: a step of this rms angle (rad) per sample, as the director
  // of a finite box wanders; 0: fixed.
  double director_step = 0.0;
};

// The everyday scene's box and body count (rho as in the paper's box).
inline SyntheticNematic everyday_box() {
  SyntheticNematic s;
  s.side = 28.5256;
  s.bodies = 2304;
  return s;
}

class Rng {
 public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return (static_cast<double>(engine_() >> 11) + 0.5) * 0x1.0p-53; }
  double normal() {  // Marsaglia's polar method; the second deviate is kept for the next call
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * uniform() - 1.0, v = 2.0 * uniform() - 1.0, s = u * u + v * v;
    } while (s >= 1.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }
  std::uint64_t below(std::uint64_t n) { return engine_() % n; }  // bias ~ n / 2^64

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

inline Vec3 unit(const Vec3 &v) { return v * (1.0 / norm(v)); }

// Any unit vector perpendicular to n (from the lab axis least aligned with n).
inline Vec3 perpendicular(const Vec3 &n) {
  const Vec3 a = std::fabs(n.x) <= std::fabs(n.y) && std::fabs(n.x) <= std::fabs(n.z)
                     ? Vec3{1, 0, 0}
                     : (std::fabs(n.y) <= std::fabs(n.z) ? Vec3{0, 1, 0} : Vec3{0, 0, 1});
  return unit(a - dot(a, n) * n);
}

// One configuration:
// 1. Director modes on the half k-lattice: dn(k) = alpha e1 + beta e2 (e1 = k_perp/|k_perp|,
//    e2 = n0 x e1), complex Gaussian with <|alpha|^2> = kT / (V (K1 k1^2 + K3 k3^2)) and
//    <|beta|^2> = kT / (V (K2 k1^2 + K3 k3^2)); dn(r) = sum_k 2 Re(dn(k) exp(i k.r)) is real
//    and, with Qk's V/N sum_i -> integral, gives <|Q_m3|^2> = (9/4) S^2 V kT / E_m3.
// 2. Local director with n1 n3 = d1, n2 n3 = d2 exactly (n3^2 = (1 + sqrt(1 - 4|d|^2))/2),
//    d = lambda dn(r): the local Q = S_mol (3/2 n n - 1/2) then has Q_m3 = (3/2) S_mol d_m,
//    linear in the field. Director fluctuations lower the measured S below S_mol by the
//    factor S_field (largest eigenvalue of the mean of 3/2 n n - 1/2), so lambda = S_field
//    (solved by iteration) makes Q_m3 = (3/2) S_measured dn_m: the paper's model, exactly.
// 3. Axis e = normalise(n + noise (g1 a + g2 b)), (a, b) orthonormal and perpendicular to n,
//    g Gaussian: uniaxial about n, so <q> = S_mol (3/2 n n - 1/2). This disorder lowers S
//    and adds the k-independent background (9/4)(V/N)^2 sum_i (e.e1)^2 (e.n)^2.
class SyntheticSampler {
 public:
  explicit SyntheticSampler(const SyntheticNematic &s)
      : s_(s),
        box_{{s.side, s.side, s.side}},
        n0_(unit(s.director)),
        modes_(half_space_modes(s.kmax)),
        base_re_(kGrid),
        base_im_(kGrid) {
    for (std::size_t m = 0; m < kGrid; ++m) {
      const double theta = 2.0 * std::numbers::pi * (static_cast<double>(m) + 0.5) / kGrid;
      base_re_[m] = std::cos(theta), base_im_[m] = std::sin(theta);
    }
  }

  const Box &box() const { return box_; }

  // A new independent run: the mode amplitudes drawn with `variance` times their stationary
  // variance (1: equilibrium; 0: the aligned start, from which mode k's variance grows as
  // 1 - exp(-2 t / tau_k)).
  void start(std::uint64_t seed, double variance = 1.0) {
    rng_ = Rng(seed);
    n0_ = unit(s_.director);
    amp_.assign(modes_.size(), {});
    for (std::size_t m = 0; m < modes_.size(); ++m) draw_mode(m, 0.0, std::sqrt(variance));
  }

  // The next sample's director modes, without placing bodies (an equilibration sample).
  void advance() {
    wander();
    for (std::size_t m = 0; m < modes_.size(); ++m) draw_mode(m, s_.tau0);
  }

  // The next sample of the run: each mode relaxes as an AR(1) process with correlation
  // exp(-1 / tau_k) per sample, tau_k = tau0 / E_k (a director mode relaxes at a rate ~ K k^2);
  // centres and molecular disorder are new every sample (they decorrelate fast).
  void next(Particles &p) {
    advance();
    place_bodies(p);
  }

  const Vec3 &director() const { return n0_; }

  // An independent sample (seeded): a new run of one sample.
  void sample(std::uint64_t seed, Particles &p) {
    start(seed);
    place_bodies(p);
  }

 private:
  // The mean director takes a random step perpendicular to itself; the modes follow it in
  // draw_mode, which projects their amplitudes on the new frame.
  void wander() {
    if (!(s_.director_step > 0.0)) return;
    const Vec3 a = perpendicular(n0_), b = cross(n0_, a);
    const double g1 = rng_.normal(), g2 = rng_.normal();
    n0_ = unit(n0_ + (s_.director_step / std::numbers::sqrt2) * (g1 * a + g2 * b));
  }

  // amp = alpha e1 + beta e2 (header comment, step 1); with tau0 > 0 the old alpha, beta decay.
  // `scale` multiplies the new part's standard deviation.
  void draw_mode(std::size_t m, double tau0, double scale = 1.0) {
    const auto &kk = modes_[m];
    const Vec3 k =
        (2.0 * std::numbers::pi / s_.side) * Vec3{double(kk[0]), double(kk[1]), double(kk[2])};
    const double k3 = dot(k, n0_);
    const Vec3 kp = k - k3 * n0_;
    const double k1sq = norm2(kp);
    const Vec3 e1 = k1sq > 1e-24 * norm2(k) ? kp * (1.0 / std::sqrt(k1sq)) : perpendicular(n0_);
    const Vec3 e2 = cross(n0_, e1);
    const double E1 = s_.K1 * k1sq + s_.K3 * k3 * k3, E2 = s_.K2 * k1sq + s_.K3 * k3 * k3;
    const double volume = box_.volume();
    const double s1 = scale * std::sqrt(s_.kT / (volume * E1) / 2.0),
                 s2 = scale * std::sqrt(s_.kT / (volume * E2) / 2.0);
    const double r1 = tau0 > 0.0 ? std::exp(-E1 / tau0) : 0.0,
                 r2 = tau0 > 0.0 ? std::exp(-E2 / tau0) : 0.0;
    const double f1 = std::sqrt(1.0 - r1 * r1), f2 = std::sqrt(1.0 - r2 * r2);
    // Project the old amplitude on e1, e2 (a real, orthonormal pair).
    const auto &old = amp_[m];
    const std::complex<double> a0 = old[0] * e1.x + old[1] * e1.y + old[2] * e1.z;
    const std::complex<double> b0 = old[0] * e2.x + old[1] * e2.y + old[2] * e2.z;
    const std::complex<double> alpha =
        r1 * a0 + f1 * std::complex<double>(s1 * rng_.normal(), s1 * rng_.normal());
    const std::complex<double> beta =
        r2 * b0 + f2 * std::complex<double>(s2 * rng_.normal(), s2 * rng_.normal());
    amp_[m] = {alpha * e1.x + beta * e2.x, alpha * e1.y + beta * e2.y, alpha * e1.z + beta * e2.z};
  }

  void place_bodies(Particles &p) {
    Rng &rng = rng_;
    const std::size_t n = s_.bodies;
    const auto &amp = amp_;
    // Centres uniform on a fine grid (kGrid^3 sites, far finer than any wavelength used),
    // so the phases of the field come from a table instead of sincos calls.
    p.resize(n);
    cell_.resize(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
      p.id[i] = static_cast<std::int64_t>(i);
      for (std::size_t a = 0; a < 3; ++a)
        cell_[3 * i + a] = static_cast<std::uint32_t>(rng.below(kGrid));
      p.set_position(i, {grid_coordinate(cell_[3 * i]), grid_coordinate(cell_[3 * i + 1]),
                         grid_coordinate(cell_[3 * i + 2])});
    }
    field_at_bodies(p, amp);
    // lambda = S_field(lambda) by fixed-point iteration (contracts by ~3 lambda^2 <dn^2>
    // per step). S_field is taken as n0 . Q_field . n0 = <3/2 n3^2 - 1/2>: the field has no
    // k = 0 mode, so n0 is its director up to O(N^-1/2) and the Rayleigh quotient is the
    // largest eigenvalue up to the square of that.
    double lambda = 1.0;
    for (int it = 0; it < 5; ++it) {
      double sum = 0.0;
      for (std::size_t i = 0; i < n; ++i) sum += 1.5 * local_n3_squared(i, lambda) - 0.5;
      lambda = sum / static_cast<double>(n);
    }
    // Local director n = n3 n0 + d / n3, then molecular disorder about it.
    const Vec3 helper = perpendicular(n0_);
    for (std::size_t i = 0; i < n; ++i) {
      const double n3 = std::sqrt(local_n3_squared(i, lambda));
      const Vec3 dir = n3 * n0_ + local_d(i, lambda) * (1.0 / n3);
      const Vec3 a = unit(cross(dir, helper)), b = cross(dir, a);
      const double g1 = rng.normal(), g2 = rng.normal();
      p.set_axis(i, unit(dir + s_.noise * (g1 * a + g2 * b)));
    }
  }

  static constexpr std::size_t kGrid = 4096;
  double grid_coordinate(std::uint32_t cell) const {
    return (static_cast<double>(cell) + 0.5) * (s_.side / kGrid);
  }

  // d = lambda dn(r_i), shortened to |d| < 1/2 in the (rare: |dn| ~ 0.15 typical) case it
  // is longer, since |n1 n3| <= 1/2 for a unit n.
  Vec3 local_d(std::size_t i, double lambda) const {
    const Vec3 d = lambda * Vec3{dx_[i], dy_[i], dz_[i]};
    const double d2 = norm2(d), limit = 0.25 * (1.0 - 1e-9);
    return d2 <= limit ? d : d * std::sqrt(limit / d2);
  }
  double local_n3_squared(std::size_t i, double lambda) const {
    return 0.5 * (1.0 + std::sqrt(1.0 - 4.0 * norm2(local_d(i, lambda))));
  }

  // dn(r_i) = sum_k 2 Re(amp_k exp(i k.r_i)), in chunks of bodies whose phase tables
  // exp(i 2 pi k c / L), k < kmax, per axis stay in cache; real arithmetic, so it vectorises.
  void field_at_bodies(const Particles &p,
                       const std::vector<std::array<std::complex<double>, 3>> &amp) {
    constexpr std::size_t kChunk = 256;
    const std::size_t n = p.size();
    const auto kmax = static_cast<std::size_t>(s_.kmax);
    std::vector<double> re(3 * kmax * kChunk), im(3 * kmax * kChunk);
    dx_.assign(n, 0.0), dy_.assign(n, 0.0), dz_.assign(n, 0.0);
    for (std::size_t i0 = 0; i0 < n; i0 += kChunk) {
      const std::size_t c = std::min(kChunk, n - i0);
      for (std::size_t axis = 0; axis < 3; ++axis) {
        double *r = re.data() + axis * kmax * kChunk, *m = im.data() + axis * kmax * kChunk;
        for (std::size_t j = 0; j < c; ++j) {
          const std::uint32_t cell = cell_[3 * (i0 + j) + axis];
          r[j] = 1.0, m[j] = 0.0;
          r[kChunk + j] = base_re_[cell], m[kChunk + j] = base_im_[cell];
        }
        for (std::size_t k = 2; k < kmax; ++k)
#pragma omp simd
          for (std::size_t j = 0; j < c; ++j) {
            const std::size_t now = k * kChunk + j, prev = now - kChunk;
            r[now] = r[prev] * r[kChunk + j] - m[prev] * m[kChunk + j];
            m[now] = r[prev] * m[kChunk + j] + m[prev] * r[kChunk + j];
          }
      }
      double *dx = dx_.data() + i0, *dy = dy_.data() + i0, *dz = dz_.data() + i0;
      for (std::size_t mode = 0; mode < modes_.size(); ++mode) {
        const auto &kk = modes_[mode];
        auto at = [&](std::size_t axis, int k) {
          return (axis * kmax + static_cast<std::size_t>(std::abs(k))) * kChunk;
        };
        const double *xr = re.data() + at(0, kk[0]), *xi = im.data() + at(0, kk[0]);
        const double *yr = re.data() + at(1, kk[1]), *yi = im.data() + at(1, kk[1]);
        const double *zr = re.data() + at(2, kk[2]), *zi = im.data() + at(2, kk[2]);
        const double sx = kk[0] < 0 ? -1.0 : 1.0, sy = kk[1] < 0 ? -1.0 : 1.0;  // conjugates
        // 2 Re(amp ph) = 2 amp.re ph.re - 2 amp.im ph.im per Cartesian component.
        const double ar[3] = {2 * amp[mode][0].real(), 2 * amp[mode][1].real(),
                              2 * amp[mode][2].real()};
        const double ai[3] = {2 * amp[mode][0].imag(), 2 * amp[mode][1].imag(),
                              2 * amp[mode][2].imag()};
#pragma omp simd
        for (std::size_t j = 0; j < c; ++j) {
          const double a = yr[j] * zr[j] - sy * yi[j] * zi[j],
                       b = yr[j] * zi[j] + sy * yi[j] * zr[j];
          const double pr = xr[j] * a - sx * xi[j] * b, pi = xr[j] * b + sx * xi[j] * a;
          dx[j] += ar[0] * pr - ai[0] * pi;
          dy[j] += ar[1] * pr - ai[1] * pi;
          dz[j] += ar[2] * pr - ai[2] * pi;
        }
      }
    }
  }

  SyntheticNematic s_;
  Box box_;
  Vec3 n0_;
  std::vector<std::array<int, 3>> modes_;
  std::vector<double> base_re_, base_im_;  // exp(i 2 pi (m + 1/2) / kGrid)
  std::vector<std::uint32_t> cell_;        // grid cell of each body per axis
  std::vector<double> dx_, dy_, dz_;       // dn at the bodies
  Rng rng_{0};
  std::vector<std::array<std::complex<double>, 3>> amp_;  // dn(k) per mode
};

// Adds `samples` configurations (seeds seed0, seed0 + 1, ...) to `acc` and, if given, to
// `control`, which is told S = 1 instead of the measured S (a deliberately wrong
// normalisation the test must notice).
// One OpenMP thread: the generator is serial, the kernel's 4 ms per call gains little from a
// second thread, and spinning threads on a loaded machine would cost more than that (the
// result does not depend on the thread count: FourierOrderTensor.BitIdentical...).
inline void accumulate(const SyntheticNematic &s, int samples, std::uint64_t seed0,
                       FrankAccumulator &acc, FrankAccumulator *control = nullptr) {
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(1);
  SyntheticSampler sampler(s);
  Particles p;
  for (int t = 0; t < samples; ++t) {
    sampler.sample(seed0 + static_cast<std::uint64_t>(t), p);
    const OrderParameter op = order_parameter(axis_moments(p, p.size()));
    const FourierOrderTensor qk = fourier_order_tensor(p, p.size(), sampler.box(), s.kmax);
    acc.add_sample(qk, op.director, op.S);
    if (control) control->add_sample(qk, op.director, 1.0);
  }
  omp_set_num_threads(saved_threads);
}

inline FrankAccumulatorConfig block_config() {
  FrankAccumulatorConfig config;
  config.samples_per_block = 10;
  return config;
}

inline FrankFitOptions fit_options(bool subtract_self_term) {
  FrankFitOptions o;
  o.kT = SyntheticNematic{}.kT;
  o.subtract_self_term = subtract_self_term;
  return o;
}

inline void report(const char *what, const FrankModelFit &f) {
  std::printf("  %-34s K1 %.4f +- %.4f  K2 %.4f +- %.4f  K3 %.4f +- %.4f  chi2/dof %.2f %.2f\n",
              what, f.K1.value, f.K1.error, f.K2.value, f.K2.error, f.K3.value, f.K3.error,
              f.chi2_13, f.chi2_23);
}

// |value - want| within `fraction` of want, and within `sigmas` times the reported error
// combined with the generator's own systematic error: rod axes are the director field plus
// noise, normalised, which maps the prescribed field to Q_m3 only to first order in the
// director fluctuation: K is prescribed to a few per cent (3 % allowed).
inline void expect_recovered(const char *name, const FrankEstimate &e, double want, double fraction,
                             double sigmas, double systematic = 0.03) {
  EXPECT_TRUE(std::isfinite(e.value) && std::isfinite(e.error) && e.error > 0.0) << name;
  EXPECT_LT(std::fabs(e.value - want), fraction * want)
      << name << " = " << e.value << " +- " << e.error;
  EXPECT_LT(std::fabs(e.value - want), sigmas * std::hypot(e.error, systematic * want))
      << name << " = " << e.value << " +- " << e.error;
}

// `runs` independent runs of `samples` consecutive (correlated, with tau0 > 0) samples each,
// from modes at `start_variance` of their equilibrium variance and after `equilibration`
// samples that are not kept (the defaults: from equilibrium, kept from the first sample).
inline std::vector<FrankAccumulator> correlated_runs(const SyntheticNematic &s, int runs,
                                                     int samples, std::uint64_t seed0,
                                                     double start_variance = 1.0,
                                                     int equilibration = 0) {
  const int saved_threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const Box box{{s.side, s.side, s.side}};
  SyntheticSampler sampler(s);
  Particles p;
  std::vector<FrankAccumulator> out;
  for (int r = 0; r < runs; ++r) {
    out.emplace_back(box, static_cast<long long>(s.bodies), s.kmax, block_config());
    sampler.start(seed0 + 7919 * static_cast<std::uint64_t>(r), start_variance);
    for (int t = 0; t < equilibration; ++t) sampler.advance();
    for (int t = 0; t < samples; ++t) {
      sampler.next(p);
      const OrderParameter op = order_parameter(axis_moments(p, p.size()));
      out.back().add_sample(fourier_order_tensor(p, p.size(), box, s.kmax), op.director, op.S);
    }
  }
  omp_set_num_threads(saved_threads);
  return out;
}

}  // namespace hardrod::synthetic
