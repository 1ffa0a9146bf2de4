// Compiled alone with -ffast-math (see lib/CMakeLists.txt): that is what lets glibc's vector
// math library (libmvec) supply a SIMD exp, 2 or 4 values per call, the difference between a
// compute-bound and a memory-bound assembly. libmvec's exp is accurate to 4 ulp. This file holds
// nothing else, so fast-math changes no other arithmetic: no reduction, no NaN test here (the
// inputs are finite, non-negative squared distances checked upstream).
#include "cpu.hpp"
#include "gaussian_kernel.hpp"

#include <algorithm>
#include <cmath>

namespace digilap {

namespace {

constexpr int kChunk = 64;  // a multiple of every vector width: no scalar prologue or epilogue

// Two versions, chosen at load time by the CPU: AVX2 (4 exp per libmvec call) and baseline
// x86-64 (SSE2, 2). Each CPU always runs the same one, so results stay reproducible.
#if DIGILAP_X86_64_GCC
__attribute__((target_clones("avx2", "default")))
#endif
void weights_of_chunk(double* chunk, double inv_4t, double scale) {
#pragma omp simd aligned(chunk : 64)
  for (int k = 0; k < kChunk; ++k) chunk[k] = scale * std::exp(-chunk[k] * inv_4t);
}

// The same with an AVX-512 version first (8 exp a call): the matrix-free surface products gain
// 8% from it; the curves' assembly lost 3-4% (euclidean distances, 2 threads), so they keep the
// one above.
#if DIGILAP_X86_64_GCC
__attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#endif
void weights_of_chunk_wide(double* chunk, double inv_4t, double scale) {
#pragma omp simd aligned(chunk : 64)
  for (int k = 0; k < kChunk; ++k) chunk[k] = scale * std::exp(-chunk[k] * inv_4t);
}

void weights_by_chunks(double* values, Eigen::Index count, double inv_4t, double scale) {
  alignas(64) double chunk[kChunk];
  for (Eigen::Index first = 0; first < count; first += kChunk) {
    const int used = static_cast<int>(std::min<Eigen::Index>(kChunk, count - first));
    std::copy(values + first, values + first + used, chunk);
    std::fill(chunk + used, chunk + kChunk, 0.0);
    weights_of_chunk(chunk, inv_4t, scale);
    std::copy(chunk, chunk + used, values + first);
  }
}

}  // namespace

// Every value goes through the same vector exp, whatever its position in the row: a scalar
// tail (the remainder of a row after the full vectors) would use the scalar exp, whose last
// bit differs, and A = M L would then not be symmetric bit for bit (the weight of a distance
// would depend on where the pair sits in each of its two rows).
void gaussian_weights(double* values, Eigen::Index count, double inv_4t, double scale) {
  weights_by_chunks(values, count, inv_4t, scale);
}

void gaussian_weights_wide(double* values, Eigen::Index count, double inv_4t, double scale) {
  const Eigen::Index room = gaussian_weights_room(count);
  std::fill(values + count, values + room, 0.0);  // finite, whatever was there
  for (Eigen::Index first = 0; first < room; first += kChunk) weights_of_chunk_wide(values + first, inv_4t, scale);
}

}  // namespace digilap
