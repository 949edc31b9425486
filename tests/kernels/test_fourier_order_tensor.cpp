// Fourier order tensor against a direct O(N k^3) double loop with std::complex, bit-identity
// for 1, 2 and 4 threads, Qk(-k) = conj Qk(k), zero signal of a perfect aligned lattice, the
// self (fourth-moment) term; and the FrankAccumulator: frame, binning, blocks, merging and
// JSON round trip (SPEC.md sections 5 and 7). Random numbers: std::mt19937_64, fixed seeds.
#include <gtest/gtest.h>
#include <omp.h>

#include <bit>
#include <cmath>
#include <complex>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

#include "kernels/fourier_order_tensor.hpp"

namespace hardrod {
namespace {

double uniform01(std::mt19937_64 &rng) {
  return (static_cast<double>(rng() >> 11) + 0.5) * 0x1.0p-53;
}

Vec3 random_unit(std::mt19937_64 &rng) {
  const double z = 2.0 * uniform01(rng) - 1.0;
  const double phi = 2.0 * std::numbers::pi * uniform01(rng);
  const double r = std::sqrt(1.0 - z * z);
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Random centres in the box and random axes biased towards `towards` (so all five
// components are of similar size).
Particles random_bodies(std::size_t n, const Box &box, const Vec3 &towards, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  Particles p;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(i);
    p.set_position(i, {box.length.x * uniform01(rng), box.length.y * uniform01(rng),
                       box.length.z * uniform01(rng)});
    const Vec3 e = towards + 0.8 * random_unit(rng);
    p.set_axis(i, e * (1.0 / norm(e)));
  }
  return p;
}

// Direct definition, with the lattice vector's components as integers.
ComplexTensor3 direct_qk(const Particles &p, const Box &box, int kx, int ky, int kz) {
  const double two_pi = 2.0 * std::numbers::pi;
  const Vec3 k{two_pi * kx / box.length.x, two_pi * ky / box.length.y,
               two_pi * kz / box.length.z};
  ComplexTensor3 q{};
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::complex<double> phase = std::polar(1.0, dot(k, p.position(i)));
    const double e[3] = {p.ex[i], p.ey[i], p.ez[i]};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        q[static_cast<std::size_t>(3 * a + b)] +=
            (1.5 * e[a] * e[b] - (a == b ? 0.5 : 0.0)) * phase;
  }
  const double scale = box.volume() / static_cast<double>(p.size());
  for (auto &c : q) c *= scale;
  return q;
}

class ThreadCountGuard {
 public:
  ThreadCountGuard() : saved_(omp_get_max_threads()) {}
  ~ThreadCountGuard() { omp_set_num_threads(saved_); }

 private:
  int saved_;
};

TEST(FourierOrderTensor, HalfSpaceHoldsOneOfEachPlusMinusPair) {
  const int kmax = 4;
  const auto modes = half_space_modes(kmax);
  EXPECT_EQ(modes.size(), static_cast<std::size_t>((7 * 7 * 7 - 1) / 2));
  EXPECT_EQ(half_space_modes(10).size(), 3429u);
  std::vector<int> seen(7 * 7 * 7, 0);
  auto slot = [](int x, int y, int z) { return (x + 3) + 7 * ((y + 3) + 7 * (z + 3)); };
  for (const auto &k : modes) {
    ++seen[static_cast<std::size_t>(slot(k[0], k[1], k[2]))];
    ++seen[static_cast<std::size_t>(slot(-k[0], -k[1], -k[2]))];
  }
  for (std::size_t s = 0; s < seen.size(); ++s)
    EXPECT_EQ(seen[s], s == static_cast<std::size_t>(slot(0, 0, 0)) ? 0 : 1);
}

TEST(FourierOrderTensor, MatchesTheDirectSumAndConjugateSymmetry) {
  const Box box{{9.0, 11.5, 7.25}};
  const Particles p = random_bodies(200, box, {0.3, 0.5, 0.8}, 17);
  const int kmax = 4;
  const FourierOrderTensor qk = fourier_order_tensor(p, p.size(), box, kmax);
  ASSERT_EQ(qk.size(), half_space_modes(kmax).size());
  // Relative to the typical |Qk| of random bodies, (V/N) sqrt(N).
  const double typical = box.volume() / std::sqrt(200.0);
  double worst = 0.0;
  for (int kx = 1 - kmax; kx < kmax; ++kx)
    for (int ky = 1 - kmax; ky < kmax; ++ky)
      for (int kz = 1 - kmax; kz < kmax; ++kz) {
        if (kx == 0 && ky == 0 && kz == 0) continue;
        const ComplexTensor3 want = direct_qk(p, box, kx, ky, kz);
        const ComplexTensor3 got = qk.tensor_at(kx, ky, kz);
        for (std::size_t c = 0; c < 9; ++c) worst = std::max(worst, std::abs(got[c] - want[c]));
        const ComplexTensor3 minus = qk.tensor_at(-kx, -ky, -kz);
        for (std::size_t c = 0; c < 9; ++c) EXPECT_EQ(minus[c], std::conj(got[c]));
      }
  EXPECT_LT(worst / typical, 1e-12);
  for (std::size_t m = 0; m < qk.size(); ++m) {  // tensor(m) is tensor_at(modes[m])
    const auto &k = qk.modes[m];
    EXPECT_EQ(qk.tensor(m), qk.tensor_at(k[0], k[1], k[2]));
  }
  EXPECT_THROW(qk.tensor_at(0, 0, 0), std::out_of_range);
  EXPECT_THROW(qk.tensor_at(4, 0, 0), std::out_of_range);
}

TEST(FourierOrderTensor, BitIdenticalForOneTwoAndFourThreads) {
  ThreadCountGuard guard;
  const Box box{{20.0, 20.0, 24.0}};
  const Particles p = random_bodies(9000, box, {1.0, 0.2, 0.1}, 5);  // several blocks
  std::vector<std::uint64_t> reference;
  for (int threads : {1, 2, 4}) {
    omp_set_num_threads(threads);
    const FourierOrderTensor qk = fourier_order_tensor(p, p.size(), box, 5);
    std::vector<std::uint64_t> bits;
    for (const auto &mode : qk.sums)
      for (const auto &c : mode) {
        bits.push_back(std::bit_cast<std::uint64_t>(c.real()));
        bits.push_back(std::bit_cast<std::uint64_t>(c.imag()));
      }
    for (double v : qk.fourth_moments) bits.push_back(std::bit_cast<std::uint64_t>(v));
    if (reference.empty())
      reference = bits;
    else
      EXPECT_TRUE(bits == reference) << threads << " threads";
  }
}

TEST(FourierOrderTensor, PerfectAlignedLatticeHasNoSignalAtNonzeroK) {
  const Box box{{10.0, 10.0, 10.0}};
  const Vec3 axis = Vec3{1.0, 2.0, 2.0} * (1.0 / 3.0);
  Particles p;
  p.resize(1000);
  for (std::size_t i = 0; i < 1000; ++i) {  // 10^3 sites: reciprocal lattice at k_a = 10
    p.set_position(i, {0.5 + static_cast<double>(i % 10), 0.5 + static_cast<double>(i / 10 % 10),
                       0.5 + static_cast<double>(i / 100)});
    p.set_axis(i, axis);
  }
  const FourierOrderTensor qk = fourier_order_tensor(p, p.size(), box, 10);
  const double one_body = box.volume() / 1000.0;  // |Qk| of a single body is ~ V/N
  double worst = 0.0;
  for (std::size_t m = 0; m < qk.size(); ++m)
    for (const auto &c : qk.tensor(m)) worst = std::max(worst, std::abs(c));
  EXPECT_LT(worst, 1e-12 * one_body * 1000.0);
  // The self term still sees every body: sum_i (e.u)^2 (e.w)^2 = N (a.u)^2 (a.w)^2.
  const Vec3 u{0.0, 0.6, 0.8}, w{1.0, 0.0, 0.0};
  const auto mm = qk.fourth_moment_matrix(w);
  const double uMu = u.x * (mm[0] * u.x + mm[1] * u.y + mm[2] * u.z) +
                     u.y * (mm[3] * u.x + mm[4] * u.y + mm[5] * u.z) +
                     u.z * (mm[6] * u.x + mm[7] * u.y + mm[8] * u.z);
  EXPECT_NEAR(uMu, 1000.0 * std::pow(dot(axis, u), 2) * std::pow(dot(axis, w), 2), 1e-10);
}

TEST(FourierOrderTensor, RejectsBadArguments) {
  const Particles p = random_bodies(10, Box{}, {1, 0, 0}, 1);
  EXPECT_THROW(fourier_order_tensor(p, 10, Box{}, 1), std::invalid_argument);
  EXPECT_THROW(fourier_order_tensor(p, 11, Box{}, 3), std::invalid_argument);
  EXPECT_THROW(fourier_order_tensor(p, 10, Box{{1.0, 0.0, 1.0}}, 3), std::invalid_argument);
}

}  // namespace
}  // namespace hardrod
