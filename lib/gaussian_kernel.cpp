// Compiled alone with -ffast-math (see lib/CMakeLists.txt): that is what lets glibc's vector
// math library (libmvec) supply a SIMD exp, 2 or 4 values per call, the difference between a
// compute-bound and a memory-bound assembly. libmvec's exp is accurate to 4 ulp. This file holds
// nothing else, so fast-math changes no other arithmetic: no reduction, no NaN test here (the
// inputs are finite, non-negative squared distances checked upstream).
#include "gaussian_kernel.hpp"

#include <cmath>

namespace digilap {

// Two versions, chosen at load time by the CPU: AVX2 (4 exp per libmvec call) and baseline
// x86-64 (SSE2, 2 per call). Each CPU always runs the same one, so results stay reproducible.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
void gaussian_weights(double* values, Eigen::Index count, double inv_4t, double scale) {
#pragma omp simd
  for (Eigen::Index k = 0; k < count; ++k) values[k] = scale * std::exp(-values[k] * inv_4t);
}

}  // namespace digilap
