// Internal: the one test for the builds that carry CPU-specific code paths (AVX2 + FMA kernels,
// target clones): x86-64 with GCC. Clang lacks the function multiversioning these use the way
// GCC does, and other CPUs take the portable code.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define DIGILAP_X86_64_GCC 1
#else
#define DIGILAP_X86_64_GCC 0
#endif
