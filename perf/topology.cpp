#include "perf/topology.hpp"

#include <fmt/format.h>
#include <hwloc.h>
#include <omp.h>

#include <cstdlib>
#include <map>
#include <string>
#include <vector>

namespace hardrod {

namespace {

// One loaded topology per process, released at exit.
hwloc_topology_t topology() {
  static hwloc_topology_t topo = [] {
    hwloc_topology_t t;
    hwloc_topology_init(&t);
    hwloc_topology_load(t);
    std::atexit([] { hwloc_topology_destroy(topology()); });
    return t;
  }();
  return topo;
}

int count(hwloc_obj_type_t type) {
  const int n = hwloc_get_nbobjs_by_type(topology(), type);
  return n < 0 ? 0 : n;
}

}  // namespace

TopologySummary describe_topology() {
  TopologySummary s;
  s.packages = count(HWLOC_OBJ_PACKAGE);
  s.cores = count(HWLOC_OBJ_CORE);
  s.processing_units = count(HWLOC_OBJ_PU);
  s.numa_nodes = count(HWLOC_OBJ_NUMANODE);
  s.description = fmt::format("{} package(s), {} NUMA node(s), {} core(s), {} hardware thread(s)",
                              s.packages, s.numa_nodes, s.cores, s.processing_units);
  return s;
}

std::string bind_threads(bool enabled) {
  if (!enabled) return "thread binding off (--no-bind)";
  if (std::getenv("OMP_PROC_BIND") || std::getenv("OMP_PLACES"))
    return "thread binding left to OpenMP (OMP_PROC_BIND / OMP_PLACES are set)";
  hwloc_topology_t topo = topology();
  hwloc_cpuset_t allowed = hwloc_bitmap_alloc();
  if (hwloc_get_cpubind(topo, allowed, HWLOC_CPUBIND_PROCESS) != 0) {
    hwloc_bitmap_free(allowed);
    return "thread binding not available (cannot read the process binding)";
  }
  // The cores inside the process's allowed set, in topology order.
  std::vector<hwloc_obj_t> cores;
  for (hwloc_obj_t core = nullptr;
       (core = hwloc_get_next_obj_covering_cpuset_by_type(topo, allowed, HWLOC_OBJ_CORE, core));)
    cores.push_back(core);
  hwloc_bitmap_free(allowed);
  if (cores.empty()) return "thread binding not available (no cores found)";
  const int threads = omp_get_max_threads();
  // Bind only a process that fills its cores: two processes sharing a machine (a bench
  // script's parallel jobs) must not pile onto the same first core.
  if (threads < 2 || static_cast<std::size_t>(threads) != cores.size())
    return fmt::format(
        "threads not bound ({} thread(s) on {} core(s) of this process: placement left to the "
        "OS; pin with OMP_PROC_BIND=close OMP_PLACES=cores or mpirun --bind-to core)",
        threads, cores.size());
  std::vector<int> failed(static_cast<std::size_t>(threads), 0);
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    hwloc_obj_t core = cores[static_cast<std::size_t>(t) % cores.size()];
    hwloc_cpuset_t set = hwloc_bitmap_dup(core->cpuset);
    hwloc_bitmap_singlify(set);  // one hardware thread of the core
    failed[static_cast<std::size_t>(t)] = hwloc_set_cpubind(topo, set, HWLOC_CPUBIND_THREAD);
    hwloc_bitmap_free(set);
  }
  int bad = 0;
  for (int f : failed) bad += f != 0;
  if (bad > 0) return fmt::format("thread binding failed for {} of {} threads", bad, threads);
  return fmt::format("bound {} thread(s) one per core over {} core(s) of this process", threads,
                     cores.size());
}

std::string thread_placement() {
  hwloc_topology_t topo = topology();
  const int threads = omp_get_max_threads();
  std::vector<int> pu(static_cast<std::size_t>(threads), -1), core(pu.size(), -1);
#pragma omp parallel num_threads(threads)
  {
    const int t = omp_get_thread_num();
    hwloc_cpuset_t where = hwloc_bitmap_alloc();
    if (hwloc_get_last_cpu_location(topo, where, HWLOC_CPUBIND_THREAD) == 0) {
      const int index = hwloc_bitmap_first(where);
      pu[static_cast<std::size_t>(t)] = index;
      hwloc_obj_t p = hwloc_get_pu_obj_by_os_index(topo, static_cast<unsigned>(index));
      hwloc_obj_t c = p ? hwloc_get_ancestor_obj_by_type(topo, HWLOC_OBJ_CORE, p) : nullptr;
      core[static_cast<std::size_t>(t)] = c ? static_cast<int>(c->logical_index) : -1;
    }
    hwloc_bitmap_free(where);
  }
  std::string out;
  if (threads <= kListedThreads) {
    for (int t = 0; t < threads; ++t)
      out += fmt::format("{}thread {} -> PU {} (core {})", t ? ", " : "", t, pu[t], core[t]);
    return out;
  }
  // Many threads: how many ran on each PU, so the line grows with the machine, not the count.
  std::map<int, std::pair<int, int>> on;  // PU -> (core, threads)
  for (int t = 0; t < threads; ++t) {
    auto &entry = on[pu[t]];
    entry.first = core[t];
    ++entry.second;
  }
  out = fmt::format("{} threads:", threads);
  for (const auto &[where, entry] : on)
    out += fmt::format(" {} on PU {} (core {}),", entry.second, where, entry.first);
  out.pop_back();
  return out;
}

}  // namespace hardrod
