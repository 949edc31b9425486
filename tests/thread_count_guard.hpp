// Restores the OpenMP thread count a test changed, however the test ends.
#pragma once

#include <omp.h>

namespace hardrod::testing {

class ThreadCountGuard {
 public:
  ThreadCountGuard() : saved_(omp_get_max_threads()) {}
  ~ThreadCountGuard() { omp_set_num_threads(saved_); }
  ThreadCountGuard(const ThreadCountGuard &) = delete;
  ThreadCountGuard &operator=(const ThreadCountGuard &) = delete;

 private:
  int saved_;
};

}  // namespace hardrod::testing
