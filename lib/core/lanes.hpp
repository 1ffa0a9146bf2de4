// Internal: the GCC vector of 8 doubles that the hand-vectorized loops use (block LDL^T solves,
// LOBPCG's tall products, the surface products and curvature terms). One AVX-512 register; two
// AVX2 ones or four SSE2 ones in the other builds of a target_clones function.
#pragma once

namespace digilap::detail {

typedef double Lanes8 __attribute__((vector_size(64)));
// The same at any 8-byte boundary: a row of a std::vector or a neighbour's values need not start
// on 64 bytes.
typedef double Lanes8u __attribute__((vector_size(64), aligned(8)));

}  // namespace digilap::detail
