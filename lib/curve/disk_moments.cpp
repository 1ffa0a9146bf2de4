#include "disk_moments.hpp"

#include "core/lattice.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace digilap::detail {

// Why row moments: the disk holds O((R/h)^2) pixels, but each of its O(R/h) rows meets the set
// in a few runs, and the moments of a run of consecutive pixels have closed forms. So a linel
// costs O(R/h) instead of O((R/h)^2), which is what makes h = 1e-4 (R/h = 464) affordable.
// Half-widths of the disk's chords: chord[d] = floor(sqrt((2 rho)^2 - d^2)) for the doubled
// vertical offsets d = 0 .. floor(2 rho), computed once for all linels (a sqrt per row and
// linel was a third of the cost).
std::vector<std::int64_t> chord_table(double rho) {
  const double r2 = 4.0 * rho * rho;
  const std::int64_t m = floor_sqrt(r2);
  std::vector<std::int64_t> chord(static_cast<std::size_t>(m) + 1);
  for (std::int64_t d = 0; d <= m; ++d) chord[static_cast<std::size_t>(d)] = floor_sqrt(r2 - static_cast<double>(d * d));
  return chord;
}

Moments disk_moments(const DigitalSet& set, std::int64_t X, std::int64_t Y, const std::vector<std::int64_t>& chord) {
  // Doubled coordinates: the disk centre is (X/2, Y/2) pixels; pixel (i, j) is inside when
  // (2i - X)^2 + (2j - Y)^2 <= (2 rho)^2.
  const auto m = static_cast<std::int64_t>(chord.size()) - 1;
  const std::int64_t i0 = floor_half(X), j0 = floor_half(Y);
  Moments mo;
  for (std::int64_t j = ceil_half(Y - m); j <= floor_half(Y + m); ++j) {
    const std::int64_t mx = chord[static_cast<std::size_t>(std::abs(2 * j - Y))];
    const std::int64_t lo = ceil_half(X - mx), hi = floor_half(X + mx);  // inclusive
    const Run* b = set.row_runs_begin(static_cast<std::int32_t>(j));
    const Run* e = set.row_runs_end(static_cast<std::int32_t>(j));
    const Run* r = std::upper_bound(b, e, lo, [](std::int64_t v, const Run& run) { return v < run.end; });
    const std::int64_t dj = j - j0;
    for (; r != e && r->begin <= hi; ++r) {
      const std::int64_t a = std::max<std::int64_t>(lo, r->begin) - i0;
      const std::int64_t c = std::min<std::int64_t>(hi, r->end - 1) - i0;
      if (c < a) continue;
      const std::int64_t count = c - a + 1, s1 = (a + c) * count / 2;
      mo.n += count;
      mo.sx += s1;
      mo.sy += dj * count;
      mo.sxx += sum_squares(c) - sum_squares(a - 1);
      mo.syy += dj * dj * count;
      mo.sxy += dj * s1;
    }
  }
  return mo;
}

}  // namespace digilap::detail
