#include "runtime/info.hpp"

#include <fmt/format.h>
#include <omp.h>

#include <thread>

#include "perf/topology.hpp"
#include "runtime/comm.hpp"

namespace hardrod {

namespace {
const char *simd_level() {
#if defined(__AVX512F__)
  return "AVX-512 (8 doubles)";
#elif defined(__AVX2__)
  return "AVX2 (4 doubles)";
#elif defined(__AVX__)
  return "AVX (4 doubles)";
#elif defined(__SSE2__)
  return "SSE2 (2 doubles)";
#else
  return "scalar";
#endif
}
}  // namespace

std::string build_info() {
  std::string s;
  s += fmt::format("hardrod {}\n", HARDROD_VERSION);
  s += fmt::format("  compiler     {}\n", HARDROD_COMPILER);
  s += fmt::format("  build type   {}\n", HARDROD_BUILD_TYPE);
  s += fmt::format("  SIMD         {}\n", simd_level());
  s += fmt::format("  FMA contract off (bit-reproducible across thread counts)\n");
  s += fmt::format("  OpenMP       {} (max threads {})\n", _OPENMP, omp_get_max_threads());
  s += fmt::format("  MPI          {}\n", Communicator::library_version());
  s += fmt::format("  hardware     {} hardware threads\n", std::thread::hardware_concurrency());
  s += fmt::format("  topology     {} (hwloc)\n", describe_topology().description);
  s += fmt::format("  binding      {}\n", bind_threads(true));
  s += fmt::format("  placement    {}\n", thread_placement());
  return s;
}

}  // namespace hardrod
