// Whole time steps of the exact method (run.method = "exact", kernels/exact/exact_collisions.hpp)
// on one thread unless asked: the everyday nematic (N = 2304, L/D = 5, rho* = 0.5) and hard
// spheres at packing fraction 0.45 (N = 32768, the system of the event-driven reference the speed
// goal is set against), each from a state relaxed by the method itself, at several dt and skins.
// Reports ns per particle-step, microseconds of CPU per particle per tau (the figure to set
// against event-driven MD), the phases, and the method's work per step (collisions, searches, gap
// evaluations per search, largest cluster). Relaxation before measuring, by the method itself at
// dt 2e-3: the nematic 40 tau (from the lattice's S = 0.93 to the equilibrium's ~0.77, where a
// step costs more than near the lattice), the spheres 4 tau (the fcc lattice has melted).
// HARDROD_BENCH_RELAX_TAU sets both.
#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>

#include "runtime/exact/exact_step.hpp"
#include "runtime/system.hpp"

namespace hardrod {
namespace {

enum Bench { kNematic = 0, kSpheres = 1 };

Scene scene_of(int system, double dt, double skin) {
  Scene s;
  s.method = kExact;
  s.dt = dt;
  s.skin = skin;
  s.thermostat_interval = 0;
  if (system == kNematic) {
    s.shape_name = "spherocylinder";
    s.shape.length = 5.0;
    s.lattice = {4, 24, 24};
    s.n = 2304;
    const double side =
        std::cbrt(static_cast<double>(s.n) / (0.5 * s.shape.close_packing_density()));
    s.box.length = {side, side, side};
  } else {
    s.shape_name = "sphere";
    s.shape.length = 0.0;
    s.lattice = {32, 32, 32};
    s.n = 32768;
    const double side = std::cbrt(static_cast<double>(s.n) * s.shape.volume() / 0.45);
    s.box.length = {side, side, side};
  }
  return s;
}

// Relaxed bodies per system, made once per process (exact method, dt 2e-3, all threads).
const Particles &relaxed_bodies(int system) {
  static std::map<int, std::unique_ptr<Particles>> cache;
  auto &slot = cache[system];
  if (!slot) {
    const char *env = std::getenv("HARDROD_BENCH_RELAX_TAU");
    const double tau = env ? std::atof(env) : (system == kNematic ? 40.0 : 4.0);
    constexpr double kRelaxDt = 2e-3;
    const int threads = omp_get_max_threads();
    omp_set_num_threads(omp_get_num_procs());  // the same bits on any threads
    System sim(scene_of(system, kRelaxDt, system == kNematic ? 1.0 : 0.3));
    sim.advance(static_cast<long long>(std::llround(tau / kRelaxDt)));
    omp_set_num_threads(threads);
    slot = std::make_unique<Particles>(sim.gather_bodies());
  }
  return *slot;
}

// Arguments: system (0 nematic, 1 spheres), dt in units of 1e-4, skin in units of 0.1 D,
// threads.
void BM_ExactStep(benchmark::State &state) {
  const int system = static_cast<int>(state.range(0));
  const double dt = 1e-4 * static_cast<double>(state.range(1));
  const double skin = 0.1 * static_cast<double>(state.range(2));
  const Particles &start = relaxed_bodies(system);
  omp_set_num_threads(static_cast<int>(state.range(3)));
  System sim(scene_of(system, dt, skin), start);
  sim.advance(20);  // the first list, outside the timing
  sim.take_interval();
  const RegionTimers before = sim.timers();
  const ExactRecord record_before = dynamic_cast<const ExactStep &>(sim.method()).record();
  long long steps = 0;
  constexpr long long kBurst = 16;
  for (auto _ : state) {
    sim.advance(kBurst);
    steps += kBurst;
  }
  const double n = static_cast<double>(sim.owned_count());
  const double particle_steps = n * static_cast<double>(steps);
  for (Region r : {Region::kIntegrate, Region::kNeighborBuild, Region::kDetect, Region::kResolve}) {
    const double ns = 1e9 * (sim.timers().seconds(r) - before.seconds(r));
    state.counters[std::string(region_name(r)) + "_ns"] = ns / particle_steps;
  }
  state.counters["ns_per_particle_step"] = benchmark::Counter(
      particle_steps * 1e-9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["us_per_particle_tau"] = benchmark::Counter(
      particle_steps * 1e-6 * dt, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  const ExactStats &a = record_before.totals,
                   &b = dynamic_cast<const ExactStep &>(sim.method()).record().totals;
  const auto per_step = [&](long long after, long long before_) {
    return static_cast<double>(after - before_) / static_cast<double>(steps);
  };
  state.counters["collisions_per_step"] = per_step(b.collisions, a.collisions);
  state.counters["searches_per_step"] = per_step(b.searches, a.searches);
  state.counters["iterations_per_search"] =
      static_cast<double>(b.root_iterations - a.root_iterations) /
      std::max(1.0, static_cast<double>(b.searches - a.searches));
  state.counters["largest_cluster"] = static_cast<double>(b.largest_cluster);
  state.counters["fallbacks"] = static_cast<double>(b.fallbacks - a.fallbacks);
}
BENCHMARK(BM_ExactStep)
    ->ArgNames({"system", "dt_1e-4", "skin_0.1", "threads"})
    ->Args({kNematic, 10, 3, 1})
    ->Args({kNematic, 10, 6, 1})
    ->Args({kNematic, 10, 10, 1})
    ->Args({kNematic, 20, 10, 1})
    ->Args({kSpheres, 20, 3, 1})
    ->Args({kSpheres, 20, 5, 1})
    ->Args({kSpheres, 20, 8, 1})
    ->Args({kSpheres, 30, 5, 1})
    ->Args({kNematic, 10, 6, 2})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// The neighbour build alone on the relaxed bodies at the exact method's skins, as a run
// rebuilds: the bodies already sorted by cell by the build before. Arguments: system, skin in
// units of 0.1 D. Per body.
void BM_ExactListBuild(benchmark::State &state) {
  const int system = static_cast<int>(state.range(0));
  const Scene scene = scene_of(system, 1e-3, 0.1 * static_cast<double>(state.range(1)));
  omp_set_num_threads(1);
  Particles p = relaxed_bodies(system);
  NeighborList list;
  list.skin = scene.skin;
  build_neighbor_list(list, p, p.size(), scene.box, scene.shape);  // the sort, outside
  for (auto _ : state) {
    build_neighbor_list(list, p, p.size(), scene.box, scene.shape);
    benchmark::DoNotOptimize(list.pairs.data());
  }
  state.counters["ns_per_body"] = benchmark::Counter(
      static_cast<double>(p.size()) * 1e-9 * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["pairs_per_body"] = static_cast<double>(list.pair_count()) / p.size();
}
BENCHMARK(BM_ExactListBuild)
    ->ArgNames({"system", "skin_0.1"})
    ->Args({kNematic, 10})
    ->Args({kSpheres, 3})
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace hardrod
