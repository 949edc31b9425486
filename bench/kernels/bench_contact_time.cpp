// Micro-benchmark of the exact contact time (first_contact, kernels/exact/contact_time.hpp).
// Physics: the nematic's collisions, L/D = 5 rods (h = 2.5, axes ~17 degrees about z, head or
// tail at random), |v| ~ 1.7 (kT = m = 1), angular velocities ~ 1 across the axis; pairs whose
// gap at the start of the step is 0 .. 0.05 D. Batches of pairs that do collide within the step
// dt (1e-2 and 1e-3), split by the contact's geometry: side by side (both closest points inside
// the axes) and end to side (one at an end); a batch of all listed pairs (most do not collide:
// the common prediction); and spheres (the closed form) at the same speeds.
// Reports ns per search (time_per_search) and evaluations per search (iterations, and the
// batch's largest, max_iterations). Also the exact method's screen (apart_in_flight) of the
// listed batch, and the listed batch over longer horizons. Single thread; fixed seeds.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "kernels/exact/contact_time.hpp"

namespace hardrod {
namespace {

constexpr int kPairs = 1024;
constexpr double kD = 1.0;

enum class Kind { side, end, listed };

struct Batch {
  std::vector<Flight> a, b;
  double h = 0.0, dt = 0.0;
};

Vec3 normal3(std::mt19937_64 &rng, double sigma) {
  std::normal_distribution<double> n(0.0, sigma);
  return {n(rng), n(rng), n(rng)};
}

Flight random_body(std::mt19937_64 &rng, bool rod) {
  Flight f;
  const Vec3 tilt = normal3(rng, 0.3);
  f.e = (1.0 / std::sqrt(1.0 + tilt.x * tilt.x + tilt.y * tilt.y)) * Vec3{tilt.x, tilt.y, 1.0};
  if (rng() & 1u) f.e = -f.e;
  f.v = normal3(rng, 1.0);
  if (rod) {
    const Vec3 w = normal3(rng, 0.7);
    f.w = w - dot(w, f.e) * f.e;
  }
  return f;
}

double gap_at(const Flight &a, const Flight &b, double h, double t) {
  const SegmentClosest c =
      segment_closest(b.position(t) - a.position(t), a.axis(t), h, b.axis(t), h);
  return std::sqrt(c.dist2) - kD;
}

Batch make_batch(Kind kind, double h, double dt, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Batch batch;
  batch.h = h;
  batch.dt = dt;
  const double reach_xy = kD + 0.05 + 0.6 * h, reach_z = 2 * h + kD + 0.05;
  while (static_cast<int>(batch.a.size()) < kPairs) {
    Flight a = random_body(rng, h > 0.0), b = random_body(rng, h > 0.0);
    b.x = {reach_xy * u(rng), reach_xy * u(rng), reach_z * u(rng)};
    const double g = gap_at(a, b, h, 0.0);
    if (g < 0.0 || g > 0.05) continue;
    if (kind != Kind::listed) {
      const ContactTime ct = first_contact(a, b, h, kD, 0.0, dt, {});
      if (!ct.found || ct.t == 0.0) continue;
      const SegmentClosest c =
          segment_closest(b.position(ct.t) - a.position(ct.t), a.axis(ct.t), h, b.axis(ct.t), h);
      const bool side = std::abs(c.s) < h && std::abs(c.t) < h;
      if (h > 0.0 && side != (kind == Kind::side)) continue;
    }
    batch.a.push_back(a);
    batch.b.push_back(b);
  }
  return batch;
}

void run(benchmark::State &state, const Batch &batch) {
  const ContactTimeSettings settings;
  long iterations = 0, largest = 0, searches = 0;
  for (auto _ : state) {
    for (int k = 0; k < kPairs; ++k) {
      const ContactTime ct =
          first_contact(batch.a[k], batch.b[k], batch.h, kD, 0.0, batch.dt, settings);
      benchmark::DoNotOptimize(ct);
      iterations += ct.iterations;
      largest = std::max<long>(largest, ct.iterations);
    }
    searches += kPairs;
  }
  state.SetItemsProcessed(searches);
  state.counters["time_per_search"] = benchmark::Counter(
      double(searches), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["iterations"] = double(iterations) / double(std::max(1L, searches));
  state.counters["max_iterations"] = double(largest);
}

void BM_FirstContact_RodsSideBySide(benchmark::State &state) {
  static const Batch batch = make_batch(Kind::side, 2.5, 1e-2, 11);
  run(state, batch);
}
void BM_FirstContact_RodsEndToSide(benchmark::State &state) {
  static const Batch batch = make_batch(Kind::end, 2.5, 1e-2, 12);
  run(state, batch);
}
void BM_FirstContact_RodsSideBySideDt1e3(benchmark::State &state) {
  static const Batch batch = make_batch(Kind::side, 2.5, 1e-3, 13);
  run(state, batch);
}
void BM_FirstContact_RodsEndToSideDt1e3(benchmark::State &state) {
  static const Batch batch = make_batch(Kind::end, 2.5, 1e-3, 14);
  run(state, batch);
}
void BM_FirstContact_RodsListedDt1e3(benchmark::State &state) {
  static const Batch batch = make_batch(Kind::listed, 2.5, 1e-3, 15);
  run(state, batch);
}
// The same listed pairs searched over a longer horizon (in units of 1e-3 tau): what a scheme
// that keeps each pair's prediction until either body's next collision would pay per
// prediction (in the equilibrated nematic a body collides every 0.026 tau, so a pair's free
// flights last about 0.013 tau).
void BM_FirstContact_RodsListedHorizon(benchmark::State &state) {
  const double horizon = 1e-3 * static_cast<double>(state.range(0));
  const Batch batch = make_batch(Kind::listed, 2.5, horizon, 15);
  run(state, batch);
}
void BM_FirstContact_Spheres(benchmark::State &state) {
  static const Batch batch = make_batch(Kind::side, 0.0, 1e-2, 16);
  run(state, batch);
}

// The exact method's screen of a candidate (apart_in_flight), from the closest points the
// detection has measured: the listed pairs at dt 1e-3. Reports ns per pair and the share
// proven apart.
void BM_ApartInFlight_RodsListedDt1e3(benchmark::State &state) {
  static const Batch batch = make_batch(Kind::listed, 2.5, 1e-3, 15);
  std::vector<SegmentClosest> closest;
  for (int k = 0; k < kPairs; ++k)
    closest.push_back(
        segment_closest(batch.b[k].x - batch.a[k].x, batch.a[k].e, batch.h, batch.b[k].e, batch.h));
  long pairs = 0, apart = 0;
  for (auto _ : state) {
    for (int k = 0; k < kPairs; ++k) {
      const bool ok = apart_in_flight(batch.a[k], batch.b[k], batch.b[k].x - batch.a[k].x,
                                      closest[k], batch.h, kD, batch.dt, kApartMargin);
      benchmark::DoNotOptimize(ok);
      apart += ok;
    }
    pairs += kPairs;
  }
  state.counters["time_per_pair"] =
      benchmark::Counter(double(pairs), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["apart_share"] = double(apart) / double(std::max(1L, pairs));
}

BENCHMARK(BM_FirstContact_RodsSideBySide);
BENCHMARK(BM_ApartInFlight_RodsListedDt1e3);
BENCHMARK(BM_FirstContact_RodsEndToSide);
BENCHMARK(BM_FirstContact_RodsSideBySideDt1e3);
BENCHMARK(BM_FirstContact_RodsEndToSideDt1e3);
BENCHMARK(BM_FirstContact_RodsListedDt1e3);
BENCHMARK(BM_FirstContact_RodsListedHorizon)->ArgName("horizon_1e-3")->Arg(1)->Arg(13)->Arg(50);
BENCHMARK(BM_FirstContact_Spheres);

}  // namespace
}  // namespace hardrod
