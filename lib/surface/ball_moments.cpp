#include "ball_moments.hpp"

#include "core/lattice.hpp"

#include <algorithm>

namespace digilap::surface::detail {

using digilap::detail::ceil_half;
using digilap::detail::floor_half;
using digilap::detail::floor_sqrt;
using digilap::detail::sum_squares;

// The ball of radius rho (voxels) around (X, Y, Z) / 2 (doubled coordinates: surfel centres are
// integers there). Each (y, z) row of the ball meets the set in a few runs, whose x-moments
// have closed forms: O(rho^2) per ball.
Moments ball_moments(const VoxelSet& set, std::int64_t X, std::int64_t Y, std::int64_t Z, double rho) {
  const double r2 = 4 * rho * rho;
  const std::int64_t m = floor_sqrt(r2);
  const std::int64_t i0 = floor_half(X), j0 = floor_half(Y), k0 = floor_half(Z);
  Moments mo;
  for (std::int64_t k = ceil_half(Z - m); k <= floor_half(Z + m); ++k) {
    const std::int64_t dz2 = (2 * k - Z) * (2 * k - Z);
    const std::int64_t my = floor_sqrt(r2 - static_cast<double>(dz2));
    for (std::int64_t j = ceil_half(Y - my); j <= floor_half(Y + my); ++j) {
      const std::int64_t mx = floor_sqrt(r2 - static_cast<double>(dz2 + (2 * j - Y) * (2 * j - Y)));
      if (mx < 0) continue;
      const std::int64_t lo = ceil_half(X - mx), hi = floor_half(X + mx);
      const Run* b = set.row_runs_begin(static_cast<std::int32_t>(j), static_cast<std::int32_t>(k));
      const Run* e = set.row_runs_end(static_cast<std::int32_t>(j), static_cast<std::int32_t>(k));
      const Run* r = std::upper_bound(b, e, lo, [](std::int64_t v, const Run& run) { return v < run.end; });
      const std::int64_t dj = j - j0, dk = k - k0;
      for (; r != e && r->begin <= hi; ++r) {
        const std::int64_t a = std::max<std::int64_t>(lo, r->begin) - i0, c = std::min<std::int64_t>(hi, r->end - 1) - i0;
        if (c < a) continue;
        const std::int64_t count = c - a + 1, sx = (a + c) * count / 2, sxx = sum_squares(c) - sum_squares(a - 1);
        mo.n += count;
        mo.s[0] += sx, mo.s[1] += dj * count, mo.s[2] += dk * count;
        mo.ss[0][0] += sxx, mo.ss[1][1] += dj * dj * count, mo.ss[2][2] += dk * dk * count;
        mo.ss[0][1] += dj * sx, mo.ss[0][2] += dk * sx, mo.ss[1][2] += dj * dk * count;
      }
    }
  }
  return mo;
}

// Doubled coordinates of a surfel's centre.
Eigen::Matrix<std::int64_t, 3, 1> doubled_centre(const Surfel& f) {
  Eigen::Matrix<std::int64_t, 3, 1> c = 2 * f.voxel.cast<std::int64_t>();
  c[f.axis] += f.sign;
  return c;
}

}  // namespace digilap::surface::detail
