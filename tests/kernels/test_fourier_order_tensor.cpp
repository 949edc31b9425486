// Fourier order tensor against a direct O(N k^3) double loop with std::complex, bit-identity
// for 1, 2 and 4 threads, Qk(-k) = conj Qk(k), zero signal of a perfect aligned lattice, the
// self (fourth-moment) term; and the FrankAccumulator: frame, binning, blocks, merging
// (docs/physics.md sections 5 and 7; its JSON: tests/runtime/test_frank_io.cpp). Random numbers:
// std::mt19937_64, fixed seeds.
#include <gtest/gtest.h>
#include <omp.h>

#include <bit>
#include <cmath>
#include <complex>
#include <cstdint>
#include <cstdio>
#include <map>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "kernels/fourier_order_tensor.hpp"
#include "tests/thread_count_guard.hpp"

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
  const Vec3 k{two_pi * kx / box.length.x, two_pi * ky / box.length.y, two_pi * kz / box.length.z};
  ComplexTensor3 q{};
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::complex<double> phase = std::polar(1.0, dot(k, p.position(i)));
    const double e[3] = {p.ex[i], p.ey[i], p.ez[i]};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        q[3 * static_cast<std::size_t>(a) + static_cast<std::size_t>(b)] +=
            (1.5 * e[a] * e[b] - (a == b ? 0.5 : 0.0)) * phase;
  }
  const double scale = box.volume() / static_cast<double>(p.size());
  for (auto &c : q) c *= scale;
  return q;
}

using testing::ThreadCountGuard;

TEST(FourierOrderTensor, HalfSpaceHoldsOneOfEachPlusMinusPair) {
  const int kmax = 4;
  const auto modes = half_space_modes(kmax);
  EXPECT_EQ(modes.size(), static_cast<std::size_t>((7 * 7 * 7 - 1) / 2));
  EXPECT_EQ(half_space_modes(10).size(), 3429u);
  std::vector<int> seen(343, 0);  // 7^3 lattice vectors
  auto slot = [](int x, int y, int z) { return (x + 3) + 7 * ((y + 3) + 7 * (z + 3)); };
  for (const auto &k : modes) {
    ++seen[static_cast<std::size_t>(slot(k[0], k[1], k[2]))];
    ++seen[static_cast<std::size_t>(slot(-k[0], -k[1], -k[2]))];
  }
  for (std::size_t s = 0; s < seen.size(); ++s)
    EXPECT_EQ(seen[s], s == static_cast<std::size_t>(slot(0, 0, 0)) ? 0 : 1);
}

// Every lattice vector of both halves, for the test's kmax = 4 and the paper's kmax = 10
// (the phase recurrence's rounding grows with k). Bodies outside [0, L) must give the same.
TEST(FourierOrderTensor, MatchesTheDirectSumAndConjugateSymmetry) {
  const Box box{{9.0, 11.5, 7.25}};
  Particles p = random_bodies(200, box, {0.3, 0.5, 0.8}, 17);
  p.x[7] += 3.0 * box.length.x, p.y[8] -= 2.0 * box.length.y;  // unfolded images
  // Relative to the typical |Qk| of random bodies, (V/N) sqrt(N).
  const double typical = box.volume() / std::sqrt(200.0);
  for (const int kmax : {4, 10}) {
    const FourierOrderTensor qk = fourier_order_tensor(p, p.size(), box, kmax);
    ASSERT_EQ(qk.size(), half_space_modes(kmax).size());
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
    EXPECT_LT(worst / typical, 1e-12) << "kmax " << kmax;
    std::printf("  kmax %d: largest |kernel - direct| / typical |Qk| = %.2e\n", kmax,
                worst / typical);
    for (std::size_t m = 0; m < qk.size(); ++m) {  // tensor(m) is tensor_at(modes[m])
      const auto &k = qk.modes[m];
      EXPECT_EQ(qk.tensor(m), qk.tensor_at(k[0], k[1], k[2]));
    }
    EXPECT_THROW(qk.tensor_at(0, 0, 0), std::out_of_range);
    EXPECT_THROW(qk.tensor_at(kmax, 0, 0), std::out_of_range);
  }
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
    const std::size_t site[3] = {i % 10, i / 10 % 10, i / 100};
    p.set_position(i, {0.5 + static_cast<double>(site[0]), 0.5 + static_cast<double>(site[1]),
                       0.5 + static_cast<double>(site[2])});
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

// ---------------------------------------------------------------------------------------
// FrankAccumulator

// One body at the origin: Qk = V q for every k, so every rotated component is known.
struct SingleBody {
  Box box{{10.0, 10.0, 10.0}};
  double theta = 0.3;
  Vec3 axis{std::sin(0.3), 0.0, std::cos(0.3)};
  FourierOrderTensor qk;
  SingleBody() {
    Particles p;
    p.resize(1);
    p.set_axis(0, axis);
    qk = fourier_order_tensor(p, 1, box, 2);
  }
};

TEST(FrankAccumulator, RotatesIntoTheDirectorFrameAndBins) {
  const SingleBody one;
  const Vec3 n{0.0, 0.0, 1.0};
  FrankAccumulatorConfig config;
  config.bin_width = 0.05;
  FrankAccumulator acc(one.box, 1, 2, config);
  acc.add_sample(one.qk, 2.0 * n, 0.9);  // the director is normalised
  // Expected per bin: e1 = k_perp / |k_perp| (x for k parallel to n: the lab axis least
  // aligned with z, first on ties), e2 = n x e1, Q_m3 = V (3/2) (a.e_m)(a.n).
  std::map<FrankBinKey, FrankBin> want;
  const double V = one.box.volume(), two_pi = 2.0 * std::numbers::pi;
  for (const auto &k : half_space_modes(2)) {
    const Vec3 kv = (two_pi / 10.0) * Vec3{double(k[0]), double(k[1]), double(k[2])};
    const Vec3 kp{kv.x, kv.y, 0.0};
    const Vec3 e1 = norm(kp) > 0 ? kp * (1.0 / norm(kp)) : Vec3{1, 0, 0};
    const Vec3 e2 = cross(n, e1);
    const double q13 = std::pow(V * 1.5 * dot(one.axis, e1) * dot(one.axis, n), 2);
    const double q23 = std::pow(V * 1.5 * dot(one.axis, e2) * dot(one.axis, n), 2);
    FrankBin &b = want[{static_cast<int>(std::floor(norm2(kp) / 0.05)),
                        static_cast<int>(std::floor(kv.z * kv.z / 0.05))}];
    ++b.count;
    b.k1sq += norm2(kp), b.k3sq += kv.z * kv.z;
    b.q13 += q13, b.q23 += q23;
    b.self13 += q13, b.self23 += q23;  // one body: all of |Q|^2 is the self term
  }
  ASSERT_EQ(acc.blocks().size(), 1u);
  const FrankBlock &block = acc.blocks()[0];
  EXPECT_EQ(block.samples, 1);
  EXPECT_DOUBLE_EQ(block.sum_S2, 0.81);
  ASSERT_EQ(block.bins.size(), want.size());
  const double scale = V * V;
  for (const auto &[key, w] : want) {
    ASSERT_TRUE(block.bins.contains(key));
    const FrankBin &got = block.bins.at(key);
    EXPECT_EQ(got.count, w.count);
    EXPECT_NEAR(got.k1sq, w.k1sq, 1e-14);
    EXPECT_NEAR(got.k3sq, w.k3sq, 1e-14);
    EXPECT_NEAR(got.q13, w.q13, 1e-12 * scale);
    EXPECT_NEAR(got.q23, w.q23, 1e-12 * scale);
    EXPECT_NEAR(got.self13, w.self13, 1e-12 * scale);
    EXPECT_NEAR(got.self23, w.self23, 1e-12 * scale);
  }
}

TEST(FrankAccumulator, BlocksCloseCompactAndMergeOnlyWhenCompatible) {
  const SingleBody one;
  FrankAccumulatorConfig config;
  config.samples_per_block = 2;
  config.max_blocks = 4;
  FrankAccumulator a(one.box, 1, 2, config), b(one.box, 1, 2, config);
  auto sizes = [](const FrankAccumulator &acc) {
    std::vector<long long> s;
    for (const FrankBlock &blk : acc.blocks()) s.push_back(blk.samples);
    return s;
  };
  for (int t = 0; t < 9; ++t) a.add_sample(one.qk, {0, 0, 1}, 0.8);
  EXPECT_EQ(sizes(a), (std::vector<long long>{4, 4, 1}));  // 4 full blocks of 2 merged
  EXPECT_EQ(a.config().samples_per_block, 4);
  for (int t = 0; t < 3; ++t) b.add_sample(one.qk, {0, 0, 1}, 0.8);
  a += b;  // [4, 4, 1, 2, 1] exceeds 4 blocks: pairs merge
  EXPECT_EQ(sizes(a), (std::vector<long long>{8, 3, 1}));
  EXPECT_EQ(a.samples(), 12);
  EXPECT_EQ(a.total().bins.begin()->second.count, 12 * b.total().bins.begin()->second.count / 3);

  FrankAccumulatorConfig other_width = config;
  other_width.bin_width = 0.02;
  FrankAccumulator c(Box{{10.0, 10.0, 11.0}}, 2, 3, other_width);
  try {
    a += c;
    ADD_FAILURE() << "merged incompatible accumulators";
  } catch (const std::invalid_argument &e) {
    const std::string what = e.what();
    for (const char *key : {"box", "body count", "kmax", "bin width"})
      EXPECT_NE(what.find(key), std::string::npos) << what;
  }
  EXPECT_THROW(c.add_sample(one.qk, {0, 0, 1}, 0.8), std::invalid_argument);
  EXPECT_THROW(a.add_sample(one.qk, {0, 0, 0}, 0.8), std::invalid_argument);
  EXPECT_THROW(a.add_sample(one.qk, {0, 0, 1}, std::nan("")), std::invalid_argument);
  FourierOrderTensor poisoned = one.qk;
  poisoned.sums[3][kQxz] = {std::nan(""), 0.0};
  EXPECT_THROW(a.add_sample(poisoned, {0, 0, 1}, 0.8), std::invalid_argument);
  EXPECT_EQ(a.samples(), 12);  // nothing was added by the failed calls
  EXPECT_THROW(FrankAccumulator(one.box, 1, 2, FrankAccumulatorConfig{0.01, 1, 3}),
               std::invalid_argument);
}

}  // namespace
}  // namespace hardrod
