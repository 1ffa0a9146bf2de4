// The kernel's exp is written here, not taken from glibc's vector math library (libmvec, which
// this file used before, built with -ffast-math for it): libmvec's AVX-512 exp cost 1.8 ns a
// value on an Intel Ice Lake server, 12% of a surface spectrum, and the one below 1.2 ns; the
// AVX2 clone 3.2 against 1.8 ns (docs/benchmarks.md, "A polynomial exp for the kernel"). It is
// Cody and Waite's: x = k ln 2 + r with k = round(x / ln 2) and |r| <= ln(2) / 2, ln 2 in two
// parts so that k ln2_hi is exact, then e^r by its Taylor polynomial of degree 13 (remainder
// below 5e-18 relative on that range) and 2^k put into the exponent's bits. Within 1.4 ulp of
// the exact value of the rounded argument, the scale included (libmvec: 3.5 ulp; the ctest
// GaussianKernel.*). Plain arithmetic, no table and no call, so that every clone vectorizes it;
// the file is built with FMA contraction (lib/CMakeLists.txt), so a CPU with FMA fuses the
// polynomial's steps (1.7 times faster) and gets the same bits on AVX2 and AVX-512.
#include "cpu.hpp"
#include "gaussian_kernel.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>

namespace digilap {

namespace {

constexpr int kChunk = 64;  // a multiple of every vector width: no scalar prologue or epilogue

// exp(x) for x <= 0 as the kernel needs it: 0 below -708 (where exp leaves the normal doubles),
// x clamped at 709 above (never reached: x is minus a squared distance).
inline double kernel_exp(double x) {
  constexpr double kLog2e = 1.4426950408889634074, kLn2Hi = 6.93147180369123816490e-01, kLn2Lo = 1.90821492927058770002e-10;
  constexpr double kRound = 0x1.8p52;  // y + kRound rounds y to an integer, held in the low bits
  constexpr std::int64_t kRoundBits = 0x4338000000000000;  // kRound's bits
  const double kept = x < -708.0 ? 0.0 : 1.0;
  x = x < -708.0 ? -708.0 : x;
  x = x > 709.0 ? 709.0 : x;
  const double shifted = x * kLog2e + kRound;
  const double k = shifted - kRound;
  const double r = (x - k * kLn2Hi) - k * kLn2Lo;
  double p = 1.0 / 6227020800.0;  // 1/13!
  p = p * r + 1.0 / 479001600.0;
  p = p * r + 1.0 / 39916800.0;
  p = p * r + 1.0 / 3628800.0;
  p = p * r + 1.0 / 362880.0;
  p = p * r + 1.0 / 40320.0;
  p = p * r + 1.0 / 5040.0;
  p = p * r + 1.0 / 720.0;
  p = p * r + 1.0 / 120.0;
  p = p * r + 1.0 / 24.0;
  p = p * r + 1.0 / 6.0;
  p = p * r + 0.5;
  p = p * r + 1.0;
  p = p * r + 1.0;
  std::int64_t bits;
  std::memcpy(&bits, &shifted, sizeof bits);
  bits = (bits - kRoundBits + 1023) << 52;  // 2^k
  double two_k;
  std::memcpy(&two_k, &bits, sizeof two_k);
  return kept * (p * two_k);
}

// Two versions, chosen at load time by the CPU: AVX2 with FMA and baseline x86-64 (SSE2, no FMA:
// its last bits differ). Each CPU always runs the same one, so results stay reproducible.
#if DIGILAP_X86_64_GCC
__attribute__((target_clones("arch=x86-64-v3", "default")))
#endif
void weights_of_chunk(double* chunk, double inv_4t, double scale) {
#pragma omp simd aligned(chunk : 64)
  for (int k = 0; k < kChunk; ++k) chunk[k] = scale * kernel_exp(-chunk[k] * inv_4t);
}

// The same with an AVX-512 version first (8 values a vector): the matrix-free surface products
// gained 8% from it with libmvec's exp; the curves' assembly lost 3-4% (euclidean distances,
// 2 threads), so they keep the one above (not measured again with this exp; both give the same
// bits on an AVX-512 CPU, GaussianKernel.BothEntryPointsGiveTheSameBits).
#if DIGILAP_X86_64_GCC
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#endif
void weights_of_chunk_wide(double* chunk, double inv_4t, double scale) {
#pragma omp simd aligned(chunk : 64)
  for (int k = 0; k < kChunk; ++k) chunk[k] = scale * kernel_exp(-chunk[k] * inv_4t);
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
