// Fourier order tensor and the Frank accumulator (see the header for the physics).
// Kernel: bodies are split into at most 64 blocks whose bounds depend on N only; a thread
// takes whole blocks and sums each in chunks of 256 bodies whose phase tables
// exp(i 2 pi k_a r_a / L_a), k_a = 0 .. kmax-1, are built by recurrence from one sincos per
// axis. For each (ky, kz) row the combined phase is formed once; one vectorised pass per
// kx >= 0 then yields the sums for +kx and -kx. Block partials are added in block order.
#include "kernels/fourier_order_tensor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>

namespace hardrod {
namespace {

constexpr std::size_t kChunk = 256;     // bodies whose phase tables stay in L1/L2 together
constexpr std::size_t kMinBlock = 256;  // smallest block (fixed bounds, any thread count)
constexpr std::size_t kMaxBlocks = 64;  // bounds the memory of the block partial sums
constexpr std::size_t kValuesPerMode = 2 * std::size_t{kQComponents};  // re, im each
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// One (ky, kz) row of the half space; its modes are first + (kx - kx_min), kx < kmax.
struct Row {
  int ky, kz, kx_min;
  std::size_t first;
};

std::vector<Row> half_space_rows(int kmax) {
  std::vector<Row> rows;
  std::size_t first = 0;
  for (int kz = 0; kz < kmax; ++kz)
    for (int ky = kz == 0 ? 0 : 1 - kmax; ky < kmax; ++ky) {
      const int kx_min = (kz == 0 && ky == 0) ? 1 : 1 - kmax;
      rows.push_back({ky, kz, kx_min, first});
      first += static_cast<std::size_t>(kmax - kx_min);
    }
  return rows;
}

// Index of (kx, ky, kz) in half_space_modes(kmax), or -1 when -k is the stored one.
long long mode_index(int kx, int ky, int kz, int kmax) {
  if (kz < 0 || (kz == 0 && (ky < 0 || (ky == 0 && kx <= 0)))) return -1;
  const long long w = 2LL * kmax - 1;
  const long long row = kz == 0 ? ky : kmax + (kz - 1) * w + (ky + kmax - 1);
  if (row == 0) return kx - 1;
  return (kmax - 1) + (row - 1) * w + (kx + kmax - 1);
}

// Per-thread phase tables of one chunk: entry [k * kChunk + j] is exp(i 2 pi k c_j / L).
struct Workspace {
  explicit Workspace(int kmax)
      : table(6 * static_cast<std::size_t>(kmax) * kChunk),
        q(kQComponents * kChunk),
        row_re(kChunk),
        row_im(kChunk) {}
  std::vector<double> table;  // x re, x im, y re, y im, z re, z im; kmax * kChunk each
  std::vector<double> q;      // q_c of body j at [c * kChunk + j]
  std::vector<double> row_re, row_im;
};

void phase_table(const double *coord, std::size_t n, double side, int kmax, double *re,
                 double *im) {
  for (std::size_t j = 0; j < n; ++j) {  // one sincos per body; harmonics by recurrence
    const double theta = kTwoPi * (coord[j] / side);
    re[j] = 1.0;
    im[j] = 0.0;
    re[kChunk + j] = std::cos(theta);
    im[kChunk + j] = std::sin(theta);
  }
  const double *c1 = re + kChunk, *s1 = im + kChunk;
  for (int k = 2; k < kmax; ++k) {
    const double *pr = re + (k - 1) * kChunk, *pi = im + (k - 1) * kChunk;
    double *__restrict nr = re + k * kChunk;
    double *__restrict ni = im + k * kChunk;
#pragma omp simd
    for (std::size_t j = 0; j < n; ++j) {
      nr[j] = pr[j] * c1[j] - pi[j] * s1[j];
      ni[j] = pr[j] * s1[j] + pi[j] * c1[j];
    }
  }
}

// sum_j q_c (a + ib)_j for the five components: out[2c] real, out[2c+1] imaginary part.
void single_sums(const double *__restrict a, const double *__restrict b, const double *__restrict q,
                 std::size_t n, double *out) {
  const double *q0 = q, *q1 = q + kChunk, *q2 = q + 2 * kChunk, *q3 = q + 3 * kChunk,
               *q4 = q + 4 * kChunk;
  double r0 = 0, r1 = 0, r2 = 0, r3 = 0, r4 = 0, i0 = 0, i1 = 0, i2 = 0, i3 = 0, i4 = 0;
#pragma omp simd reduction(+ : r0, r1, r2, r3, r4, i0, i1, i2, i3, i4)
  for (std::size_t j = 0; j < n; ++j) {
    r0 += q0[j] * a[j], r1 += q1[j] * a[j], r2 += q2[j] * a[j], r3 += q3[j] * a[j];
    r4 += q4[j] * a[j];
    i0 += q0[j] * b[j], i1 += q1[j] * b[j], i2 += q2[j] * b[j], i3 += q3[j] * b[j];
    i4 += q4[j] * b[j];
  }
  const double r[] = {r0, r1, r2, r3, r4}, i[] = {i0, i1, i2, i3, i4};
  for (std::size_t c = 0; c < kQComponents; ++c) out[2 * c] = r[c], out[2 * c + 1] = i[c];
}

// With row phase a + ib and kx phase c + id: (a+ib)(c+id) = (ac - bd) + i(ad + bc) is the
// +kx phase, (a+ib)(c-id) = (ac + bd) + i(bc - ad) the -kx one. Sums q_c ac, q_c bd, q_c ad,
// q_c bc over bodies, then both results: plus/minus[2c] real, [2c+1] imaginary part.
void pair_sums(const double *__restrict a, const double *__restrict b, const double *__restrict c,
               const double *__restrict d, const double *__restrict q, std::size_t n, double *plus,
               double *minus) {
  const double *q0 = q, *q1 = q + kChunk, *q2 = q + 2 * kChunk, *q3 = q + 3 * kChunk,
               *q4 = q + 4 * kChunk;
  double ac0 = 0, ac1 = 0, ac2 = 0, ac3 = 0, ac4 = 0, bd0 = 0, bd1 = 0, bd2 = 0, bd3 = 0, bd4 = 0,
         ad0 = 0, ad1 = 0, ad2 = 0, ad3 = 0, ad4 = 0, bc0 = 0, bc1 = 0, bc2 = 0, bc3 = 0, bc4 = 0;
#pragma omp simd reduction(+ : ac0, ac1, ac2, ac3, ac4, bd0, bd1, bd2, bd3, bd4, ad0, ad1, \
                               ad2, ad3, ad4, bc0, bc1, bc2, bc3, bc4)
  for (std::size_t j = 0; j < n; ++j) {
    const double ac = a[j] * c[j], bd = b[j] * d[j], ad = a[j] * d[j], bc = b[j] * c[j];
    ac0 += q0[j] * ac, ac1 += q1[j] * ac, ac2 += q2[j] * ac, ac3 += q3[j] * ac;
    ac4 += q4[j] * ac;
    bd0 += q0[j] * bd, bd1 += q1[j] * bd, bd2 += q2[j] * bd, bd3 += q3[j] * bd;
    bd4 += q4[j] * bd;
    ad0 += q0[j] * ad, ad1 += q1[j] * ad, ad2 += q2[j] * ad, ad3 += q3[j] * ad;
    ad4 += q4[j] * ad;
    bc0 += q0[j] * bc, bc1 += q1[j] * bc, bc2 += q2[j] * bc, bc3 += q3[j] * bc;
    bc4 += q4[j] * bc;
  }
  const double ac[] = {ac0, ac1, ac2, ac3, ac4}, bd[] = {bd0, bd1, bd2, bd3, bd4},
               ad[] = {ad0, ad1, ad2, ad3, ad4}, bc[] = {bc0, bc1, bc2, bc3, bc4};
  for (std::size_t k = 0; k < kQComponents; ++k) {
    plus[2 * k] = ac[k] - bd[k], plus[2 * k + 1] = ad[k] + bc[k];
    minus[2 * k] = ac[k] + bd[k], minus[2 * k + 1] = bc[k] - ad[k];
  }
}

// Adds bodies [i0, i0 + n), n <= kChunk, to one block's partial sums.
void add_chunk(const Particles &p, std::size_t i0, std::size_t n, const Box &box, int kmax,
               const std::vector<Row> &rows, Workspace &ws, double *partial) {
  const std::size_t k_stride = static_cast<std::size_t>(kmax) * kChunk;
  double *t = ws.table.data();
  phase_table(p.x.data() + i0, n, box.length.x, kmax, t, t + k_stride);
  phase_table(p.y.data() + i0, n, box.length.y, kmax, t + 2 * k_stride, t + 3 * k_stride);
  phase_table(p.z.data() + i0, n, box.length.z, kmax, t + 4 * k_stride, t + 5 * k_stride);
  const double *ex = p.ex.data() + i0, *ey = p.ey.data() + i0, *ez = p.ez.data() + i0;
  double *q = ws.q.data();
  double m[15] = {};
  for (std::size_t j = 0; j < n; ++j) {
    q[kQxx * kChunk + j] = 1.5 * (ex[j] * ex[j]) - 0.5;
    q[kQyy * kChunk + j] = 1.5 * (ey[j] * ey[j]) - 0.5;
    q[kQxy * kChunk + j] = 1.5 * (ex[j] * ey[j]);
    q[kQxz * kChunk + j] = 1.5 * (ex[j] * ez[j]);
    q[kQyz * kChunk + j] = 1.5 * (ey[j] * ez[j]);
    const double x = ex[j], y = ey[j], z = ez[j];
    const double xx = x * x, yy = y * y, zz = z * z;
    const double mono[15] = {xx * xx, xx * (x * y), xx * (x * z), xx * yy,      xx * (y * z),
                             xx * zz, (x * y) * yy, (x * z) * yy, (x * y) * zz, (x * z) * zz,
                             yy * yy, yy * (y * z), yy * zz,      (y * z) * zz, zz * zz};
    for (int s = 0; s < 15; ++s) m[s] += mono[s];
  }
  for (int s = 0; s < 15; ++s) partial[s] += m[s];  // a block's first 15 entries
  double *modes = partial + 15;

  const double *yre = t + 2 * k_stride, *yim = t + 3 * k_stride;
  const double *zre = t + 4 * k_stride, *zim = t + 5 * k_stride;
  double plus[kValuesPerMode], minus[kValuesPerMode];
  for (const Row &r : rows) {
    const double y_sign = r.ky < 0 ? -1.0 : 1.0;  // exp(-i phi) = conj exp(i phi)
    const std::size_t ky = static_cast<std::size_t>(std::abs(r.ky)) * kChunk;
    const std::size_t kz = static_cast<std::size_t>(r.kz) * kChunk;
    double *__restrict a = ws.row_re.data();
    double *__restrict b = ws.row_im.data();
#pragma omp simd
    for (std::size_t j = 0; j < n; ++j) {
      const double cy = yre[ky + j], sy = y_sign * yim[ky + j];
      a[j] = cy * zre[kz + j] - sy * zim[kz + j];
      b[j] = cy * zim[kz + j] + sy * zre[kz + j];
    }
    auto add_mode = [&](int kx, const double *v) {
      double *dst = modes + (r.first + static_cast<std::size_t>(kx - r.kx_min)) * kValuesPerMode;
      for (std::size_t s = 0; s < kValuesPerMode; ++s) dst[s] += v[s];
    };
    if (r.kx_min < 0) {
      single_sums(a, b, q, n, plus);
      add_mode(0, plus);
    }
    for (int kx = 1; kx < kmax; ++kx) {
      pair_sums(a, b, t + kx * kChunk, t + k_stride + kx * kChunk, q, n, plus, minus);
      add_mode(kx, plus);
      if (r.kx_min < 0) add_mode(-kx, minus);
    }
  }
}

}  // namespace

std::vector<std::array<int, 3>> half_space_modes(int kmax) {
  std::vector<std::array<int, 3>> modes;
  for (const Row &r : half_space_rows(kmax))
    for (int kx = r.kx_min; kx < kmax; ++kx) modes.push_back({kx, r.ky, r.kz});
  return modes;
}

double FourierOrderTensor::scale() const {
  return bodies > 0 ? box.volume() / static_cast<double>(bodies)
                    : std::numeric_limits<double>::quiet_NaN();
}

Vec3 FourierOrderTensor::wavevector(std::size_t m) const {
  const std::array<int, 3> &k = modes[m];
  return {kTwoPi * k[0] / box.length.x, kTwoPi * k[1] / box.length.y, kTwoPi * k[2] / box.length.z};
}

ComplexTensor3 FourierOrderTensor::tensor(std::size_t m) const {
  const double s = scale();
  const auto &v = sums[m];
  const std::complex<double> xx = s * v[kQxx], yy = s * v[kQyy], xy = s * v[kQxy], xz = s * v[kQxz],
                             yz = s * v[kQyz];
  return {xx, xy, xz, xy, yy, yz, xz, yz, -(xx + yy)};
}

ComplexTensor3 FourierOrderTensor::tensor_at(int kx, int ky, int kz) const {
  if (std::abs(kx) >= kmax || std::abs(ky) >= kmax || std::abs(kz) >= kmax ||
      (kx == 0 && ky == 0 && kz == 0))
    throw std::out_of_range("FourierOrderTensor::tensor_at: k outside the computed lattice");
  const long long m = mode_index(kx, ky, kz, kmax);
  if (m >= 0) return tensor(static_cast<std::size_t>(m));
  ComplexTensor3 t = tensor(static_cast<std::size_t>(mode_index(-kx, -ky, -kz, kmax)));
  for (auto &c : t) c = std::conj(c);
  return t;
}

std::array<double, 9> FourierOrderTensor::fourth_moment_matrix(const Vec3 &w) const {
  // M_ab = sum_cd T_abcd w_c w_d, where T_abcd is the moment of the monomial x^p y^q z^r
  // with (p, q, r) the numbers of x, y, z among (a, b, c, d); that monomial sits at
  // (4-p)(5-p)/2 + (4-p-q) in the order (4,0,0), (3,1,0), (3,0,1), (2,2,0), ...
  const double wv[3] = {w.x, w.y, w.z};
  std::array<double, 9> out{};
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      for (int c = 0; c < 3; ++c)
        for (int d = 0; d < 3; ++d) {
          int e[3] = {0, 0, 0};
          ++e[a], ++e[b], ++e[c], ++e[d];
          const int index = (4 - e[0]) * (5 - e[0]) / 2 + (4 - e[0] - e[1]);
          out[3 * static_cast<std::size_t>(a) + static_cast<std::size_t>(b)] +=
              wv[c] * wv[d] * fourth_moments[static_cast<std::size_t>(index)];
        }
  return out;
}

FourierOrderTensor fourier_order_tensor(const Particles &p, std::size_t count, const Box &box,
                                        int kmax) {
  if (kmax < 2)
    throw std::invalid_argument("fourier_order_tensor: kmax must be >= 2, got " +
                                std::to_string(kmax));
  for (double side : {box.length.x, box.length.y, box.length.z})
    if (!(std::isfinite(side) && side > 0.0))
      throw std::invalid_argument("fourier_order_tensor: box side " + std::to_string(side) +
                                  " is not finite and positive");
  if (count > p.size())
    throw std::invalid_argument("fourier_order_tensor: count " + std::to_string(count) +
                                " exceeds the " + std::to_string(p.size()) + " bodies held");
  FourierOrderTensor out;
  out.box = box;
  out.bodies = static_cast<long long>(count);
  out.kmax = kmax;
  out.modes = half_space_modes(kmax);
  const std::vector<Row> rows = half_space_rows(kmax);
  const std::size_t stride = 15 + out.modes.size() * kValuesPerMode;

  std::size_t block = std::max(kMinBlock, (count + kMaxBlocks - 1) / kMaxBlocks);
  block = (block + kChunk - 1) / kChunk * kChunk;  // whole chunks: same lanes for every block
  const std::size_t blocks = (count + block - 1) / block;
  std::vector<double> partial(blocks * stride, 0.0);
#pragma omp parallel
  {
    Workspace ws(kmax);
#pragma omp for schedule(static)
    for (std::size_t b = 0; b < blocks; ++b) {
      const std::size_t end = std::min(count, (b + 1) * block);
      for (std::size_t i0 = b * block; i0 < end; i0 += kChunk)
        add_chunk(p, i0, std::min(kChunk, end - i0), box, kmax, rows, ws,
                  partial.data() + b * stride);
    }
  }
  std::vector<double> total(stride, 0.0);
  const auto entries = static_cast<std::ptrdiff_t>(stride);
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t e = 0; e < entries; ++e) {
    double s = 0.0;  // block order: fixed for any thread count
    for (std::size_t b = 0; b < blocks; ++b) s += partial[b * stride + static_cast<std::size_t>(e)];
    total[static_cast<std::size_t>(e)] = s;
  }
  std::copy(total.begin(), total.begin() + 15, out.fourth_moments.begin());
  out.sums.resize(out.modes.size());
  for (std::size_t m = 0; m < out.modes.size(); ++m)
    for (int c = 0; c < kQComponents; ++c) {
      const double *v = total.data() + 15 + m * kValuesPerMode + 2 * static_cast<std::size_t>(c);
      out.sums[m][static_cast<std::size_t>(c)] = {v[0], v[1]};
    }
  return out;
}

// ---------------------------------------------------------------------------------------
// FrankAccumulator

FrankBin &FrankBin::operator+=(const FrankBin &o) {
  count += o.count;
  k1sq += o.k1sq, k3sq += o.k3sq;
  k1sq_sq += o.k1sq_sq, k1sq_k3sq += o.k1sq_k3sq, k3sq_sq += o.k3sq_sq;
  q13 += o.q13, q13sq += o.q13sq, q23 += o.q23, q23sq += o.q23sq;
  self13 += o.self13, self23 += o.self23;
  return *this;
}

FrankBin &FrankBin::operator-=(const FrankBin &o) {
  count -= o.count;
  k1sq -= o.k1sq, k3sq -= o.k3sq;
  k1sq_sq -= o.k1sq_sq, k1sq_k3sq -= o.k1sq_k3sq, k3sq_sq -= o.k3sq_sq;
  q13 -= o.q13, q13sq -= o.q13sq, q23 -= o.q23, q23sq -= o.q23sq;
  self13 -= o.self13, self23 -= o.self23;
  return *this;
}

FrankBlock &FrankBlock::operator+=(const FrankBlock &o) {
  samples += o.samples;
  sum_S2 += o.sum_S2;
  for (const auto &[key, bin] : o.bins) bins[key] += bin;
  return *this;
}

FrankBlock &FrankBlock::operator-=(const FrankBlock &o) {
  samples -= o.samples;
  sum_S2 -= o.sum_S2;
  for (const auto &[key, bin] : o.bins) {
    auto it = bins.find(key);
    if (it == bins.end()) throw std::invalid_argument("FrankBlock: subtracting a bin not held");
    it->second -= bin;
    if (it->second.count <= 0) bins.erase(it);
  }
  return *this;
}

FrankAccumulator::FrankAccumulator(const Box &box, long long bodies, int kmax,
                                   FrankAccumulatorConfig config)
    : box_(box), bodies_(bodies), kmax_(kmax), config_(config) {
  std::string problems;
  if (!(box.volume() > 0.0 && std::isfinite(box.volume()))) problems += " box volume not positive;";
  if (bodies <= 0) problems += " bodies <= 0;";
  if (kmax < 2) problems += " kmax < 2;";
  if (!(config.bin_width > 0.0 && std::isfinite(config.bin_width))) problems += " bin_width <= 0;";
  if (config.samples_per_block < 1) problems += " samples_per_block < 1;";
  if (config.max_blocks < 2 || config.max_blocks % 2 != 0) problems += " max_blocks not even >= 2;";
  if (!problems.empty()) throw std::invalid_argument("FrankAccumulator:" + problems);
}

namespace {

// What add_sample refuses, as "; "-ended phrases ("" if nothing): another box, body count or
// kmax than the accumulator's, a director that is not finite and nonzero, S or Qk not finite.
std::string sample_problems(const FourierOrderTensor &qk, const Box &box, long long bodies,
                            int kmax, const Vec3 &director, double S) {
  std::string problems;
  if (qk.box.length.x != box.length.x || qk.box.length.y != box.length.y ||
      qk.box.length.z != box.length.z)
    problems += " box differs;";
  if (qk.bodies != bodies) problems += " body count differs;";
  if (qk.kmax != kmax || qk.size() != qk.sums.size()) problems += " kmax differs;";
  const double length = norm(director);
  if (!(std::isfinite(length) && length > 0.0)) problems += " director not finite and nonzero;";
  if (!std::isfinite(S)) problems += " S not finite;";
  bool finite = true;
  for (const auto &mode : qk.sums)
    for (const auto &c : mode)
      finite = finite && std::isfinite(c.real()) && std::isfinite(c.imag());
  if (!finite) problems += " Qk not finite;";
  return problems;
}

// The e1 of a k parallel to the director n: the lab axis least aligned with n, projected.
Vec3 e1_along(const Vec3 &n) {
  const double an[3] = {std::fabs(n.x), std::fabs(n.y), std::fabs(n.z)};
  const int least = an[0] <= an[1] ? (an[0] <= an[2] ? 0 : 2) : (an[1] <= an[2] ? 1 : 2);
  const Vec3 axis = least == 0 ? Vec3{1, 0, 0} : least == 1 ? Vec3{0, 1, 0} : Vec3{0, 0, 1};
  return (axis - dot(axis, n) * n) * (1.0 / norm(axis - dot(axis, n) * n));
}

// Mode m in the director frame: k's parts square to n and along it, and |e1 . Qk n|^2,
// |e2 . Qk n|^2 with e1 along k's square part (e1_parallel when k is along n), e2 = n x e1.
struct ModeProjection {
  double k1sq, k3, q13, q23;
  Vec3 e1, e2;
};
ModeProjection project_mode(const FourierOrderTensor &qk, std::size_t m, const Vec3 &n,
                            const Vec3 &e1_parallel) {
  ModeProjection out;
  const Vec3 k = qk.wavevector(m);
  out.k3 = dot(k, n);
  const Vec3 k_perp = k - out.k3 * n;
  out.k1sq = norm2(k_perp);
  out.e1 = out.k1sq > 1e-24 * norm2(k) ? k_perp * (1.0 / std::sqrt(out.k1sq)) : e1_parallel;
  out.e2 = cross(n, out.e1);
  const ComplexTensor3 q = qk.tensor(m);
  std::complex<double> qn[3];  // Qk n
  for (std::size_t a = 0; a < 3; ++a)
    qn[a] = q[3 * a] * n.x + q[3 * a + 1] * n.y + q[3 * a + 2] * n.z;
  out.q13 = std::norm(out.e1.x * qn[0] + out.e1.y * qn[1] + out.e1.z * qn[2]);
  out.q23 = std::norm(out.e2.x * qn[0] + out.e2.y * qn[1] + out.e2.z * qn[2]);
  return out;
}

}  // namespace

void FrankAccumulator::add_sample(const FourierOrderTensor &qk, const Vec3 &director, double S) {
  const std::string problems = sample_problems(qk, box_, bodies_, kmax_, director, S);
  if (!problems.empty()) throw std::invalid_argument("FrankAccumulator::add_sample:" + problems);
  if (blocks_.empty() || blocks_.back().samples >= config_.samples_per_block) {
    if (static_cast<int>(blocks_.size()) >= config_.max_blocks) compact();
    if (blocks_.empty() || blocks_.back().samples >= config_.samples_per_block)
      blocks_.emplace_back();
  }
  FrankBlock &block = blocks_.back();
  const Vec3 n = director * (1.0 / norm(director));
  const Vec3 e1_parallel = e1_along(n);
  const std::array<double, 9> M = qk.fourth_moment_matrix(n);
  auto self_part = [&](const Vec3 &u) {  // u M u = sum_i (e_i . u)^2 (e_i . n)^2
    return u.x * (M[0] * u.x + M[1] * u.y + M[2] * u.z) +
           u.y * (M[3] * u.x + M[4] * u.y + M[5] * u.z) +
           u.z * (M[6] * u.x + M[7] * u.y + M[8] * u.z);
  };
  const double self_scale = 2.25 * qk.scale() * qk.scale();  // (3/2)^2 (V/N)^2
  const double inv_width = 1.0 / config_.bin_width;
  for (std::size_t m = 0; m < qk.size(); ++m) {
    const ModeProjection pr = project_mode(qk, m, n, e1_parallel);
    const double k1sq = pr.k1sq, k3sq = pr.k3 * pr.k3;
    const FrankBinKey key{static_cast<int>(std::floor(k1sq * inv_width)),
                          static_cast<int>(std::floor(k3sq * inv_width))};
    FrankBin &bin = block.bins[key];
    ++bin.count;
    bin.k1sq += k1sq, bin.k3sq += k3sq;
    bin.k1sq_sq += k1sq * k1sq, bin.k1sq_k3sq += k1sq * k3sq, bin.k3sq_sq += k3sq * k3sq;
    bin.q13 += pr.q13, bin.q13sq += pr.q13 * pr.q13, bin.q23 += pr.q23,
        bin.q23sq += pr.q23 * pr.q23;
    bin.self13 += self_scale * self_part(pr.e1), bin.self23 += self_scale * self_part(pr.e2);
  }
  ++block.samples;
  block.sum_S2 += S * S;
}

void FrankAccumulator::compact() {
  std::vector<FrankBlock> merged;
  for (std::size_t b = 0; b < blocks_.size(); b += 2) {
    merged.push_back(std::move(blocks_[b]));
    if (b + 1 < blocks_.size()) merged.back() += blocks_[b + 1];
  }
  blocks_ = std::move(merged);
  config_.samples_per_block *= 2;
}

FrankAccumulator &FrankAccumulator::operator+=(const FrankAccumulator &o) {
  std::string problems;
  if (o.box_.length.x != box_.length.x || o.box_.length.y != box_.length.y ||
      o.box_.length.z != box_.length.z)
    problems += " box differs;";
  if (o.bodies_ != bodies_) problems += " body count differs;";
  if (o.kmax_ != kmax_) problems += " kmax differs;";
  if (o.config_.bin_width != config_.bin_width) problems += " bin width differs;";
  if (!problems.empty()) throw std::invalid_argument("FrankAccumulator merge:" + problems);
  const std::vector<FrankBlock> appended = o.blocks_;  // a copy: o may be *this
  blocks_.insert(blocks_.end(), appended.begin(), appended.end());
  config_.samples_per_block = std::max(config_.samples_per_block, o.config_.samples_per_block);
  while (static_cast<int>(blocks_.size()) > config_.max_blocks) compact();
  return *this;
}

FrankBlock FrankAccumulator::total() const {
  FrankBlock sum;
  for (const FrankBlock &b : blocks_) sum += b;
  return sum;
}

std::array<FrankAccumulator, 2> FrankAccumulator::halves() const {
  std::array<FrankAccumulator, 2> out{FrankAccumulator(box_, bodies_, kmax_, config_),
                                      FrankAccumulator(box_, bodies_, kmax_, config_)};
  const long long all = samples();
  long long seen = 0;
  for (const FrankBlock &b : blocks_) {
    out[2 * seen < all ? 0 : 1].restore_block(b);
    seen += b.samples;
  }
  return out;
}

long long FrankAccumulator::samples() const {
  long long s = 0;
  for (const FrankBlock &b : blocks_) s += b.samples;
  return s;
}

}  // namespace hardrod
