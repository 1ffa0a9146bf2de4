// The intrinsic kernel's distances over one run of grid items (surfel_grid.hpp), the inner loop
// of every intrinsic row: the assembled operator, the matrix-free products and the curvature
// factors.
#include "surfel_grid.hpp"

namespace digilap::surface::detail {

// Written as a loop without branches or compaction so that it vectorizes (the compaction was in
// the same loop before, and the division under the select kept it scalar: 30% of a
// matrix-free spectrum's time). The division uses |s|^2 where it is kept and 1 elsewhere, so no
// lane divides by zero; the arrays do not overlap (__restrict: else too many checks to vectorize). This file is built with -ffp-contract=off (lib/CMakeLists.txt): the
// clones and the scalar tail then round alike, and the bits do not depend on the CPU.
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void intrinsic_distances(
    const double* __restrict x, const double* __restrict y, const double* __restrict z, const double* __restrict nx,
    const double* __restrict ny, const double* __restrict nz, std::size_t count, const double* q, const double* nq,
    double* __restrict chord2, double* __restrict d2) {
  const double qx = q[0], qy = q[1], qz = q[2], mx = nq[0], my = nq[1], mz = nq[2];
  for (std::size_t u = 0; u < count; ++u) {
    const double dx = x[u] - qx, dy = y[u] - qy, dz = z[u] - qz;
    const double sx = nx[u] + mx, sy = ny[u] + my, sz = nz[u] + mz;
    const double ex = nx[u] - mx, ey = ny[u] - my, ez = nz[u] - mz;
    const double c2 = dx * dx + dy * dy + dz * dz;
    const double s2 = sx * sx + sy * sy + sz * sz;
    const double height = dx * sx + dy * sy + dz * sz, bend = dx * ex + dy * ey + dz * ez;
    const bool shared = s2 > 2;  // a common tangent plane: normals less than 90 degrees apart
    const double intrinsic = c2 - height * height / (shared ? s2 : 1.0) + bend * bend / 12;
    chord2[u] = c2;
    d2[u] = shared ? intrinsic : c2;
  }
}

}  // namespace digilap::surface::detail
