// Internal: exact integer helpers on the lattice, shared by the disk moments (2D) and the ball
// moments (3D) of the Integral Invariant estimators: halves of doubled coordinates, integer
// square roots of chord lengths, sums of squares of runs.
#pragma once

#include <cmath>
#include <cstdint>

namespace digilap::detail {

/// floor(a / 2) and ceil(a / 2) for signed a.
inline std::int64_t floor_half(std::int64_t a) { return a >= 0 ? a / 2 : -((-a + 1) / 2); }
inline std::int64_t ceil_half(std::int64_t a) { return -floor_half(-a); }

/// Largest m >= 0 with m^2 <= q, exact despite sqrt rounding; -1 for q < 0 (an empty chord).
inline std::int64_t floor_sqrt(double q) {
  if (q < 0) return -1;
  auto m = static_cast<std::int64_t>(std::sqrt(q));
  while (m > 0 && static_cast<double>(m) * m > q) --m;
  while (static_cast<double>(m + 1) * (m + 1) <= q) ++m;
  return m;
}

/// Sum of i^2 for i = 0..n as a polynomial: valid for negative n too (P(n) - P(n-1) = n^2).
inline std::int64_t sum_squares(std::int64_t n) { return n * (n + 1) * (2 * n + 1) / 6; }

}  // namespace digilap::detail
