// Test helper: f() computed with n OpenMP threads, the caller's thread count restored after;
// the thread-determinism tests compare on_threads(1, f) with on_threads(2, f) bit for bit.
#pragma once

#include <omp.h>

template <class F>
auto on_threads(int n, F&& f) {
  const int before = omp_get_max_threads();
  omp_set_num_threads(n);
  auto result = f();
  omp_set_num_threads(before);
  return result;
}
