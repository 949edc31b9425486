// Fourier order tensor of the paper's scene size (N = 18432 in a cubic box of side 57.0512,
// centres uniform, axes near x) on one thread, kmax = 10 (3429 half-space modes) and the
// test's kmax = 4. Reports the time per call (min/median/max over repetitions when run with
// --benchmark_repetitions) and ns per (body x k-vector), with both +-k counted as the one
// stored mode. Budget (SPEC.md section 5, one sample per 10^4 steps): well under the cost of
// 1000 time steps, ~1000 x 18432 x 50 ns = 0.9 s.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>

#include "kernels/fourier_order_tensor.hpp"

namespace hardrod {
namespace {

Particles paper_like_bodies(const Box &box, std::size_t n) {
  std::mt19937_64 rng(2014);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> tilt(0.0, 0.3);
  Particles p;
  p.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    p.id[i] = static_cast<std::int64_t>(i);
    p.set_position(i,
                   {box.length.x * unit(rng), box.length.y * unit(rng), box.length.z * unit(rng)});
    const Vec3 e{1.0, tilt(rng), tilt(rng)};
    p.set_axis(i, e * (1.0 / norm(e)));
  }
  return p;
}

void BM_FourierOrderTensor(benchmark::State &state) {
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const int kmax = static_cast<int>(state.range(0));
  const Box box{{57.0512, 57.0512, 57.0512}};
  const std::size_t n = 18432;
  const Particles p = paper_like_bodies(box, n);
  std::size_t modes = 0;
  for (auto _ : state) {
    const FourierOrderTensor qk = fourier_order_tensor(p, n, box, kmax);
    modes = qk.size();
    benchmark::DoNotOptimize(qk.sums.data());
  }
  omp_set_num_threads(saved);
  const double pairs = static_cast<double>(n) * static_cast<double>(modes);
  state.counters["modes"] = static_cast<double>(modes);
  // Seconds per iteration x 1e9 / (bodies x modes): ns per body and k-vector.
  state.counters["ns_per_body_k"] = benchmark::Counter(
      pairs * 1e-9, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
  state.counters["ms_per_call"] = benchmark::Counter(
      1e-3, benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_FourierOrderTensor)->Arg(10)->Arg(4)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace hardrod
