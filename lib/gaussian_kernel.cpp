// Compiled alone with -ffast-math (see lib/CMakeLists.txt): that is what lets glibc's vector
// math library (libmvec) supply a SIMD exp, 2 or 4 values per call, the difference between a
// compute-bound and a memory-bound assembly. libmvec's exp is accurate to 4 ulp. This file holds
// nothing else, so fast-math changes no other arithmetic: no reduction, no NaN test here (the
// inputs are finite, non-negative squared distances checked upstream).
#include "gaussian_kernel.hpp"

#include <cmath>

namespace digilap {

void gaussian_weights(double* values, Eigen::Index count, double inv_4t, double scale) {
#pragma omp simd
  for (Eigen::Index k = 0; k < count; ++k) values[k] = scale * std::exp(-values[k] * inv_4t);
}

}  // namespace digilap
