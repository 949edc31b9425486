// Fourier order tensor Qk_ab(k) = (V/N) sum_i (3/2 e_ia e_ib - 1/2 d_ab) exp(i k.r_i) on the
// box's k-lattice, and the accumulator of |Qk_13|^2, |Qk_23|^2 in the director frame from
// which frank_fit.hpp gets the Frank constants (docs/physics.md section 5; Allen & Frenkel, PRA 37,
// 1813 (1988); seed paper, "Frank elastic constants"). Reads x, y, z, ex, ey, ez of bodies
// [0, count). Threading: OpenMP over particle blocks whose bounds depend on the body count
// only, partials merged in block order: the same bits for any thread count (docs/physics.md section
// 7). No files or JSON here: the accumulator's file, frank.json, is runtime/frank_io.hpp's.
#pragma once

#include <array>
#include <complex>
#include <cstddef>
#include <map>
#include <utility>
#include <vector>

#include "kernels/box.hpp"
#include "kernels/particles.hpp"
#include "kernels/vec3.hpp"

namespace hardrod {

// The five independent components of the traceless symmetric Qk; zz = -(xx + yy).
enum QComponent : int { kQxx = 0, kQyy, kQxy, kQxz, kQyz, kQComponents };

using ComplexTensor3 = std::array<std::complex<double>, 9>;  // row-major 3x3

// Integer wave vectors (kx, ky, kz) with -kmax < k_a < kmax and k != 0, one of each +-k
// pair (Qk(-k) = conj Qk(k)): kz > 0, or kz = 0 and ky > 0, or kz = ky = 0 and kx > 0.
// Order: kz, then ky, then kx ascending. (2 kmax - 1)^3 / 2 of them: 3429 for kmax = 10.
std::vector<std::array<int, 3>> half_space_modes(int kmax);

struct FourierOrderTensor {
  Box box;
  long long bodies = 0;  // N
  int kmax = 0;
  std::vector<std::array<int, 3>> modes;  // half_space_modes(kmax)
  // sum_i q_i,c exp(i k.r_i) per mode and QComponent c; not yet scaled by V/N, so that the
  // sums of disjoint body sets (ranks) add.
  std::vector<std::array<std::complex<double>, kQComponents>> sums;
  // sum_i e_x^p e_y^q e_z^r for the 15 (p, q, r) with p + q + r = 4, in the order
  // (4,0,0), (3,1,0), (3,0,1), (2,2,0), (2,1,1), (2,0,2), (1,3,0), ..., (0,0,4). They give
  // the uncorrelated-rod (i = j, "self") part of |Qk|^2 in any frame.
  std::array<double, 15> fourth_moments{};

  std::size_t size() const { return modes.size(); }
  double scale() const;                        // V / N (NaN without bodies)
  Vec3 wavevector(std::size_t m) const;        // 2 pi (kx/Lx, ky/Ly, kz/Lz) of mode m
  ComplexTensor3 tensor(std::size_t m) const;  // Qk of mode m, scaled by V/N
  // Qk at any lattice vector -kmax < k_a < kmax, k != 0 (conjugated from the stored half).
  ComplexTensor3 tensor_at(int kx, int ky, int kz) const;
  // M_ab = sum_i (e_i . w)^2 e_ia e_ib (row-major), so sum_i (e_i . u)^2 (e_i . w)^2 = u M u.
  std::array<double, 9> fourth_moment_matrix(const Vec3 &w) const;
};

// Qk for all half_space_modes(kmax) of bodies [0, count). Positions may lie anywhere (only
// exp(i k.r) enters, periodic in the box). Throws std::invalid_argument for kmax < 2, a box
// side that is not finite and positive, or count > p.size(). Cost: about 25 flops per body
// and mode (separable phase tables, two modes +-kx per pass, no transcendental in the loop).
FourierOrderTensor fourier_order_tensor(const Particles &p, std::size_t count, const Box &box,
                                        int kmax = 10);

// ---------------------------------------------------------------------------------------
// FrankAccumulator: per sample, rotate Qk into the frame (e1, e2, n) with n the director,
// e1 = k_perp / |k_perp| (k in the 1-3 plane) and e2 = n x e1, and add |Qk_13|^2, |Qk_23|^2
// to the bin (floor(k1^2 / w), floor(k3^2 / w)). Only the stored half of k space is used:
// -k carries the same |Q_m3|^2 and (k1^2, k3^2), so it would only double-count. For k
// parallel to n, e1 is the normalised projection of the lab axis least aligned with n.
// Samples are grouped in blocks of consecutive samples (a block is closed after
// samples_per_block samples); frank_fit.hpp jackknifes over blocks. When max_blocks blocks
// are full, neighbours merge pairwise and samples_per_block doubles, so the storage stays
// bounded for any run length while >= max_blocks / 2 blocks remain for the error estimate.
// Serial (about 3429 modes per sample: microseconds next to the Fourier sum itself).

struct FrankBin {
  long long count = 0;        // k vectors added (over samples)
  double k1sq = 0, k3sq = 0;  // sums of k1^2, k3^2: the fit uses the bin means
  // Sums of k1^4, k1^2 k3^2, k3^4: the spread of (k1^2, k3^2) within the bin, from which
  // the fit corrects E for averaging 1/E over a bin of finite width.
  double k1sq_sq = 0, k1sq_k3sq = 0, k3sq_sq = 0;
  double q13 = 0, q13sq = 0;      // sums of |Q_13|^2 and |Q_13|^4
  double q23 = 0, q23sq = 0;      // the same for Q_23
  double self13 = 0, self23 = 0;  // sums of the uncorrelated-rod part of |Q_13|^2, |Q_23|^2
  FrankBin &operator+=(const FrankBin &o);
  FrankBin &operator-=(const FrankBin &o);
};

using FrankBinKey = std::pair<int, int>;  // (floor(k1^2 / w), floor(k3^2 / w))

struct FrankBlock {
  long long samples = 0;
  double sum_S2 = 0;  // sum over samples of S^2
  std::map<FrankBinKey, FrankBin> bins;
  FrankBlock &operator+=(const FrankBlock &o);
  FrankBlock &operator-=(const FrankBlock &o);  // bins whose count drops to 0 are erased
};

struct FrankAccumulatorConfig {
  double bin_width = 0.01;  // in k1^2 and k3^2, units D^-2
  long long samples_per_block = 20;
  int max_blocks = 32;  // even, >= 2
};

class FrankAccumulator {
 public:
  FrankAccumulator(const Box &box, long long bodies, int kmax, FrankAccumulatorConfig config = {});

  // qk must come from the same box, body count and kmax; director finite and nonzero
  // (normalised here); S finite. A non-finite Qk throws std::invalid_argument.
  void add_sample(const FourierOrderTensor &qk, const Vec3 &director, double S);

  // Merging runs: blocks of `o` are appended (then compacted to max_blocks). Box, body
  // count, kmax and bin width must agree exactly; every mismatch is listed in the throw.
  FrankAccumulator &operator+=(const FrankAccumulator &o);

  FrankBlock total() const;
  const std::vector<FrankBlock> &blocks() const { return blocks_; }
  long long samples() const;
  const Box &box() const { return box_; }
  long long bodies() const { return bodies_; }
  int kmax() const { return kmax_; }
  const FrankAccumulatorConfig &config() const { return config_; }

  // The production's first and second half (by samples, at a block boundary): for the check
  // that the two halves agree.
  std::array<FrankAccumulator, 2> halves() const;

  // A block as saved, appended without merging: for the reader of a saved accumulator
  // (runtime/frank_io.hpp), which restores the blocks in their order.
  void restore_block(FrankBlock block) { blocks_.push_back(std::move(block)); }

 private:
  void compact();  // merge neighbouring blocks pairwise
  Box box_;
  long long bodies_;
  int kmax_;
  FrankAccumulatorConfig config_;
  std::vector<FrankBlock> blocks_;
};

}  // namespace hardrod
