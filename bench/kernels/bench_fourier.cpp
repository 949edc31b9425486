// Fourier order tensor (kernels/fourier_order_tensor.cpp) at the paper's size: N = 18432 in
// a cubic box of side 57.0512, centres uniform, axes near x, one thread; kmax = 10 (3429
// half-space modes, the paper's -10 < k_a < 10) and the synthetic test's kmax = 4 (171).
// Counters: ns_per_body_k = time / (N x modes), one stored mode standing for +-k. Run with
// --benchmark_repetitions=5 for min/median/max. Budget (docs/physics.md section 5, one sample per
// 10^4 steps): below 1000 time steps of the paper's scene, ~1000 x 18432 x 50 ns = 0.9 s.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <random>
#include <vector>

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
  double seconds = 0.0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const FourierOrderTensor qk = fourier_order_tensor(p, n, box, kmax);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    modes = qk.size();
    benchmark::DoNotOptimize(qk.sums.data());
  }
  omp_set_num_threads(saved);
  const double calls = static_cast<double>(state.iterations());
  state.counters["modes"] = static_cast<double>(modes);
  state.counters["ns_per_body_k"] =
      seconds * 1e9 / (calls * static_cast<double>(n) * static_cast<double>(modes));
}
BENCHMARK(BM_FourierOrderTensor)
    ->Arg(10)
    ->Arg(4)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->ComputeStatistics("min",
                        [](const std::vector<double> &v) {
                          return *std::min_element(v.begin(), v.end());
                        })
    ->ComputeStatistics("max", [](const std::vector<double> &v) {
      return *std::max_element(v.begin(), v.end());
    });

}  // namespace
}  // namespace hardrod
