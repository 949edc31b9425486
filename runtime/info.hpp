// What this build is and where it runs: compiler, flags, SIMD, OpenMP (and, with the
// runtime issue, MPI and the hwloc topology). Printed by `hardrod info`.
#pragma once

#include <string>

namespace hardrod {

std::string build_info();

}  // namespace hardrod
