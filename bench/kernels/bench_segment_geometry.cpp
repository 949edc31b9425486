// Micro-benchmark of the narrow phase: segment_closest over a batch of candidate pairs.
// Physics: L/D = 5 rods (h = 2.5) in a nematic-like state (axes within ~20 degrees of x,
// head-tail symmetric, so half the pairs are nearly anti-parallel), centres within the
// Verlet cut-off L + D + skin = 6.3; and the sphere case (h = 0) on the same centres.
// Reports pairs per second (items) and time per pair, for the library call and the inline
// header body. Single thread; fixed seed.
#include <benchmark/benchmark.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "kernels/segment_geometry.hpp"

namespace hardrod {
namespace {

constexpr int kPairs = 4096;  // 4096 x 7 Vec3s: 700 kB, the working set of a cell sweep
constexpr double kCutoff = 6.3;
constexpr double kSpreadDeg = 20.0;

struct PairBatch {
  std::vector<Vec3> r, e_i, e_j;
};

Vec3 nematic_axis(std::mt19937_64 &rng) {
  std::normal_distribution<double> tilt(0.0, kSpreadDeg * std::numbers::pi / 180.0);
  const double a = tilt(rng), b = tilt(rng);
  Vec3 e{1.0, std::tan(a), std::tan(b)};
  e = (1.0 / norm(e)) * e;
  return (rng() & 1u) ? -e : e;  // nematic: no head or tail
}

const PairBatch &batch() {
  static const PairBatch pairs = [] {
    std::mt19937_64 rng(20240601);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    PairBatch p;
    while (static_cast<int>(p.r.size()) < kPairs) {
      const Vec3 r{kCutoff * u(rng), kCutoff * u(rng), kCutoff * u(rng)};
      if (norm2(r) > kCutoff * kCutoff) continue;  // uniform in the cut-off sphere
      p.r.push_back(r);
      p.e_i.push_back(nematic_axis(rng));
      p.e_j.push_back(nematic_axis(rng));
    }
    return p;
  }();
  return pairs;
}

// Kernel: segment_closest (the library call) or segment_closest_inline (the header body).
template <SegmentClosest (*Kernel)(const Vec3 &, const Vec3 &, double, const Vec3 &, double)>
void run(benchmark::State &state, double h) {
  const PairBatch &p = batch();
  benchmark::DoNotOptimize(h);  // a run-time value, as in a traversal: no constant folding
  for (auto _ : state) {
    double overlaps = 0.0;
    for (int k = 0; k < kPairs; ++k) {
      const SegmentClosest c = Kernel(p.r[k], p.e_i[k], h, p.e_j[k], h);
      overlaps += c.dist2 < 1.0 ? 1.0 : 0.0;
      benchmark::DoNotOptimize(c);
    }
    benchmark::DoNotOptimize(overlaps);
  }
  const double pairs = static_cast<double>(state.iterations()) * kPairs;
  state.SetItemsProcessed(static_cast<int64_t>(pairs));
  // Inverted rate: CPU seconds per pair, printed with an SI prefix (e.g. "9.5ns").
  state.counters["time_per_pair"] =
      benchmark::Counter(pairs, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_SegmentClosest_Rods(benchmark::State &state) { run<segment_closest>(state, 2.5); }
void BM_SegmentClosest_Spheres(benchmark::State &state) { run<segment_closest>(state, 0.0); }
void BM_SegmentClosestInline_Rods(benchmark::State &state) {
  run<segment_closest_inline>(state, 2.5);
}
void BM_SegmentClosestInline_Spheres(benchmark::State &state) {
  run<segment_closest_inline>(state, 0.0);
}

BENCHMARK(BM_SegmentClosest_Rods);
BENCHMARK(BM_SegmentClosest_Spheres);
BENCHMARK(BM_SegmentClosestInline_Rods);
BENCHMARK(BM_SegmentClosestInline_Spheres);

}  // namespace
}  // namespace hardrod
