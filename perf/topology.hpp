// The machine as hwloc sees it, and where the threads of this process run. At start-up
// each rank binds its OpenMP threads one per core when they exactly fill the cores the
// launcher gave the process (mpirun --bind-to, or the whole machine), unless the user
// pinned them already (OMP_PROC_BIND / OMP_PLACES) or switched it off (--no-bind).
// Reports describe the topology and each thread's core, for the run log and `hardrod info`.
#pragma once

#include <string>
#include <vector>

namespace hardrod {

struct TopologySummary {
  int packages = 0, cores = 0, processing_units = 0, numa_nodes = 0;
  std::string description;  // one line
};

TopologySummary describe_topology();

// Binds OpenMP thread t to the t-th core of the process's allowed cpuset when the threads
// fill those cores. Returns a line saying what it did, or why not.
std::string bind_threads(bool enabled);

// "thread 0 -> PU 0 (core 0), thread 1 -> PU 1 (core 1)": where each OpenMP thread of this
// process last ran; past kListedThreads threads, how many ran on each PU.
inline constexpr int kListedThreads = 16;
std::string thread_placement();

}  // namespace hardrod
