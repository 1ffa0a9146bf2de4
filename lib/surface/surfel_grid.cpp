// The intrinsic kernel's distances over one run of grid items (surfel_grid.hpp), the inner loop
// of every intrinsic row: the assembled operator, the matrix-free products and the curvature
// factors.
#include "surfel_grid.hpp"

#include <limits>

namespace digilap::surface::detail {

namespace {
// Candidate u's chord c2 and intrinsic squared distance from q (normal nq), returned: the tangent
// chord (tangent_chord, surfel_grid.hpp) plus the geodesic term, 1 / 12 as a product (no double
// division).
__attribute__((always_inline)) inline double intrinsic_square(const double* __restrict x, const double* __restrict y,
                                                             const double* __restrict z, const double* __restrict nx,
                                                             const double* __restrict ny, const double* __restrict nz, std::size_t u,
                                                             const double* q, const double* nq, double& c2) {
  const TangentChord t = tangent_chord(x, y, z, nx, ny, nz, u, q, nq);
  const double ex = nx[u] - nq[0], ey = ny[u] - nq[1], ez = nz[u] - nq[2];
  const double bend = t.dx * ex + t.dy * ey + t.dz * ez;
  c2 = t.chord2;
  return t.shared ? t.rho2 + bend * bend * (1.0 / 12) : t.chord2;
}
}  // namespace

// Written as loops without branches or compaction so that they vectorize (the compaction was in
// the same loop before, and the division under the select kept it scalar: 30% of a
// matrix-free spectrum's time); the arrays do not overlap (__restrict: else too many checks to
// vectorize). This file is built with -ffp-contract=off (lib/CMakeLists.txt): the clones and
// the scalar tail then round alike, and the bits do not depend on the CPU.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void intrinsic_distances(
    const double* __restrict x, const double* __restrict y, const double* __restrict z, const double* __restrict nx,
    const double* __restrict ny, const double* __restrict nz, std::size_t count, const double* q, const double* nq,
    double* __restrict chord2, double* __restrict d2) {
  for (std::size_t u = 0; u < count; ++u) {
    double c2;
    d2[u] = intrinsic_square(x, y, z, nx, ny, nz, u, q, nq, c2);
    chord2[u] = c2;
  }
}

__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void upper_intrinsic_distances(
    const double* __restrict x, const double* __restrict y, const double* __restrict z, const double* __restrict nx,
    const double* __restrict ny, const double* __restrict nz, const int* __restrict col, std::size_t count, const double* q,
    const double* nq, double cut2, int self, double* __restrict d2) {
  constexpr double kOut = std::numeric_limits<double>::infinity();
  for (std::size_t u = 0; u < count; ++u) {
    double c2;
    const double d = intrinsic_square(x, y, z, nx, ny, nz, u, q, nq, c2);
    d2[u] = c2 <= cut2 && col[u] > self ? d : kOut;
  }
}

}  // namespace digilap::surface::detail
