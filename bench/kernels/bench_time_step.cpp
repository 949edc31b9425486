// Whole time steps of the paper's scene (N = 18432, L/D = 5, rho* = 0.5) and the everyday
// scene (N = 2304) on one thread, from a state relaxed away from the lattice, at the
// paper's dt = 2e-6 and at dt = 1e-4. Reports ns per particle-step split by phase
// (neighbor_build = broad phase, detect = lazy pair filter + narrow phase, resolve,
// integrate) and microseconds of CPU per rod per simulated tau. The "limit" benchmark runs
// only the integration: the floor a full step is measured against.
// Relaxation before measuring: HARDROD_BENCH_RELAX_TAU (default 1 tau at dt = 1e-4).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>

#include "kernels/contact_detection.hpp"
#include "kernels/free_flight.hpp"
#include "kernels/neighbor_list.hpp"
#include "runtime/start.hpp"
#include "runtime/system.hpp"

namespace hardrod {
namespace {

Scene nematic_scene(int halvings, double dt) {
  Scene s;
  s.shape_name = "spherocylinder";
  s.shape.length = 5.0;
  const long long nx = 8 >> halvings, nyz = 48 >> halvings;
  s.lattice = {nx, nyz, nyz};
  s.n = nx * nyz * nyz;
  const double side = std::cbrt(static_cast<double>(s.n) / (0.5 * s.shape.close_packing_density()));
  s.box.length = {side, side, side};
  s.dt = dt;
  s.thermostat_interval = 200;
  return s;
}

// Relaxed bodies per scene size, made once per process.
const Particles &relaxed_bodies(int halvings) {
  static std::map<int, std::unique_ptr<Particles>> cache;
  auto &slot = cache[halvings];
  if (!slot) {
    const char *env = std::getenv("HARDROD_BENCH_RELAX_TAU");
    const double tau = env ? std::atof(env) : 1.0;
    omp_set_num_threads(1);
    System sim(nematic_scene(halvings, 1e-4));
    const auto steps = static_cast<long long>(std::llround(tau / 1e-4));
    for (long long k = 0; k < steps; ++k) sim.step();
    slot = std::make_unique<Particles>(sim.particles());
  }
  return *slot;
}

void add_region_counters(benchmark::State &state, const RegionTimers &before,
                         const RegionTimers &after, double particle_steps) {
  for (Region r : {Region::kIntegrate, Region::kNeighborBuild, Region::kDetect, Region::kResolve,
                   Region::kThermostat}) {
    const double ns = 1e9 * (after.seconds(r) - before.seconds(r));
    state.counters[std::string(region_name(r)) + "_ns"] = ns / particle_steps;
  }
}

// ns per particle-step (wall time when the benchmark uses real time) and items per second.
void report_particle_steps(benchmark::State &state, double particle_steps) {
  state.counters["ns_per_particle_step"] = benchmark::Counter(
      particle_steps * 1e-9, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.SetItemsProcessed(static_cast<long long>(particle_steps));
}

// Arguments: halvings (0 = paper's N = 18432, 1 = everyday N = 2304), dt in units of 1e-6.
void BM_TimeStep(benchmark::State &state) {
  const int halvings = static_cast<int>(state.range(0));
  const double dt = 1e-6 * static_cast<double>(state.range(1));
  omp_set_num_threads(static_cast<int>(state.range(2)));
  System sim(nematic_scene(halvings, dt), relaxed_bodies(halvings));
  for (int k = 0; k < 20; ++k) sim.step();  // build the neighbour list outside the timing
  sim.take_interval();
  const RegionTimers before = sim.timers();
  long long steps = 0;
  // Bursts of 64 steps, as the run loop advances between its samples (half steps fused).
  constexpr long long kBurst = 64;
  for (auto _ : state) {
    sim.advance(kBurst);
    steps += kBurst;
  }
  const double n = static_cast<double>(sim.owned_count());
  const double particle_steps = n * static_cast<double>(steps);
  const IntervalTotals t = sim.take_interval();
  add_region_counters(state, before, sim.timers(), particle_steps);
  report_particle_steps(state, particle_steps);
  state.counters["us_per_rod_tau"] = benchmark::Counter(
      particle_steps * 1e-6 * dt, benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["narrow_tests_per_step"] = static_cast<double>(t.narrow_phase_tests) / steps;
  state.counters["contacts_per_step"] = static_cast<double>(t.contacts) / steps;
  state.counters["pairs_per_rod"] = static_cast<double>(sim.neighbor_list().pair_count()) / n;
}
BENCHMARK(BM_TimeStep)
    ->ArgNames({"halvings", "dt_1e-6", "threads"})
    ->Args({0, 2, 1})
    ->Args({0, 100, 1})
    ->Args({1, 2, 1})
    ->Args({1, 100, 1})
    ->Args({0, 2, 2})  // two threads: the ratio to the first line is the kernel's scaling
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

// The floor: both half steps of free flight and nothing else (separate passes; see
// BM_IntegrateFused for the one pass per step that a run of steps makes). The motion
// constants are computed once, as between two velocity changes (BM_RefreshMotion).
void BM_IntegrateOnly(benchmark::State &state) {
  const int halvings = static_cast<int>(state.range(0));
  omp_set_num_threads(1);
  Particles p = relaxed_bodies(halvings);
  const Scene scene = nematic_scene(halvings, 2e-6);
  refresh_motion(p, p.size(), scene.shape, 1e-6);
  for (auto _ : state) {
    free_flight(p, p.size(), scene.shape, 1e-6, 1);
    free_flight(p, p.size(), scene.shape, 1e-6, 1);
    benchmark::ClobberMemory();
  }
  const double particle_steps = static_cast<double>(p.size()) * state.iterations();
  report_particle_steps(state, particle_steps);
}
BENCHMARK(BM_IntegrateOnly)->ArgNames({"halvings"})->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// The pass over the whole pair list alone (detect_contacts_all_pairs, the reference the
// watches replace while few bodies are flagged), on bodies that do not move between calls:
// every motion bound set to a mid-lifetime value (a quarter of the skin), so the narrow
// phase runs where the slack is used up. Against BM_TimeStep's detect_ns at the same thread
// count it shows what a step's detection saves, or pays, against streaming every pair.
void BM_DetectOnly(benchmark::State &state) {
  const int halvings = static_cast<int>(state.range(0));
  omp_set_num_threads(static_cast<int>(state.range(1)));
  Particles p = relaxed_bodies(halvings);
  const Scene scene = nematic_scene(halvings, 2e-6);
  NeighborList list;
  list.skin = scene.skin;
  build_neighbor_list(list, p, p.size(), scene.box, scene.shape);
  std::fill(p.motion_bound.begin(), p.motion_bound.end(), 0.25 * scene.skin);
  std::vector<Contact> contacts;
  detect_contacts_all_pairs(p, scene.box, scene.shape, list, contacts);  // settle the slacks
  for (auto _ : state) {
    detect_contacts_all_pairs(p, scene.box, scene.shape, list, contacts);
    benchmark::DoNotOptimize(contacts.data());
  }
  const double particle_steps = static_cast<double>(p.size()) * state.iterations();
  report_particle_steps(state, particle_steps);
  state.counters["pairs_per_rod"] = static_cast<double>(list.pair_count()) / p.size();
}
BENCHMARK(BM_DetectOnly)
    ->ArgNames({"halvings", "threads"})
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

// The floor of a run of steps: the second half of one step and the first half of the next
// in one pass (System::advance between samples).
void BM_IntegrateFused(benchmark::State &state) {
  const int halvings = static_cast<int>(state.range(0));
  omp_set_num_threads(static_cast<int>(state.range(1)));
  Particles p = relaxed_bodies(halvings);
  const Scene scene = nematic_scene(halvings, 2e-6);
  refresh_motion(p, p.size(), scene.shape, 1e-6);
  for (auto _ : state) {
    free_flight(p, p.size(), scene.shape, 1e-6, 2);
    benchmark::ClobberMemory();
  }
  const double particle_steps = static_cast<double>(p.size()) * state.iterations();
  report_particle_steps(state, particle_steps);
}
BENCHMARK(BM_IntegrateFused)
    ->ArgNames({"halvings", "threads"})
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

// What a change of every velocity costs the free flight (the thermostat, the rotor
// constraints, a rebuild): the motion constants of all bodies, per body.
void BM_RefreshMotion(benchmark::State &state) {
  const int halvings = static_cast<int>(state.range(0));
  omp_set_num_threads(static_cast<int>(state.range(1)));
  Particles p = relaxed_bodies(halvings);
  const Scene scene = nematic_scene(halvings, 2e-6);
  for (auto _ : state) {
    refresh_motion(p, p.size(), scene.shape, 1e-6);
    benchmark::ClobberMemory();
  }
  const double bodies = static_cast<double>(p.size()) * state.iterations();
  report_particle_steps(state, bodies);
}
BENCHMARK(BM_RefreshMotion)
    ->ArgNames({"halvings", "threads"})
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

// Times whole list builds of `bodies` (a copy per call, so every call sorts the same input);
// counters per body, as the list is built per body. Returns the last list.
NeighborList time_list_builds(benchmark::State &state, const Particles &bodies, const Box &box,
                              const Shape &shape, double skin) {
  const char *pairs_per = shape.is_sphere() ? "pairs_per_body" : "pairs_per_rod";
  NeighborList list;
  list.skin = skin;
  for (auto _ : state) {
    state.PauseTiming();
    Particles p = bodies;
    state.ResumeTiming();
    build_neighbor_list(list, p, p.size(), box, shape);
    benchmark::DoNotOptimize(list.pairs.data());
  }
  state.counters["ns_per_body"] = benchmark::Counter(
      static_cast<double>(bodies.size()) * 1e-9 * static_cast<double>(state.iterations()),
      benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters[pairs_per] = static_cast<double>(list.pair_count()) / bodies.size();
  return list;
}

// The broad phase alone: cell list, body sort and pair list of the relaxed bodies.
void BM_NeighborBuild(benchmark::State &state) {
  const int halvings = static_cast<int>(state.range(0));
  omp_set_num_threads(static_cast<int>(state.range(1)));
  const Scene scene = nematic_scene(halvings, 1e-4);
  time_list_builds(state, relaxed_bodies(halvings), scene.box, scene.shape, scene.skin);
}
BENCHMARK(BM_NeighborBuild)
    ->ArgNames({"halvings", "threads"})
    ->ArgsProduct({{0, 1}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

// The broad phase of one rank's bodies in a large system: the relaxed 2304-rod nematic in
// a corner of a box `scale` times wider along each axis (as a rank of a scale^3 grid holds
// its own subdomain; its halo left out). Scales 4 and 10 give the same list (at 1 the
// box's periodic images add pairs); the cost must not grow with the box. Per body.
void BM_NeighborBuildInLargeBox(benchmark::State &state) {
  const double scale = static_cast<double>(state.range(0));
  omp_set_num_threads(1);
  const Scene scene = nematic_scene(1, 1e-4);
  Particles local = relaxed_bodies(1);
  for (std::size_t i = 0; i < local.size(); ++i)  // folded into the corner cell of the grid
    local.set_position(i, scene.box.wrap(local.position(i)));
  Box box = scene.box;
  box.length = scale * box.length;
  const NeighborList list = time_list_builds(state, local, box, scene.shape, scene.skin);
  state.counters["cells_stored"] = static_cast<double>(list.cells.cell_count());
}
BENCHMARK(BM_NeighborBuildInLargeBox)
    ->ArgName("scale")
    ->Arg(1)
    ->Arg(4)
    ->Arg(10)
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

// The broad phase of hard spheres on their lattice (20^3 = 8000): a dense fluid's density
// (packing fraction 0.45) and a dilute gas's (0.05), where most cells are empty. Per body.
void BM_NeighborBuildSpheres(benchmark::State &state) {
  const double eta = state.range(0) == 0 ? 0.45 : 0.05;
  omp_set_num_threads(static_cast<int>(state.range(1)));
  Scene scene;
  scene.shape_name = "sphere";
  scene.shape.length = 0.0;
  scene.lattice = {20, 20, 20};
  scene.n = 8000;
  const double side = std::cbrt(8000.0 * scene.shape.volume() / eta);
  scene.box.length = {side, side, side};
  time_list_builds(state, initial_bodies(scene), scene.box, scene.shape, scene.skin);
}
BENCHMARK(BM_NeighborBuildSpheres)
    ->ArgNames({"dilute", "threads"})
    ->ArgsProduct({{0, 1}, {1}})
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace hardrod
