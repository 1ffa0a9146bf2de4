#include "digilap/normals.hpp"

#include "digilap/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>
#include <sstream>

namespace digilap {

namespace {

// Exact integer moments of the pixel centres in a disk, in pixel units relative to a nearby
// pixel (so that the sums stay small and exact).
struct Moments {
  std::int64_t n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
};

// Sum of i^2 for i = 0..n as a polynomial: valid for negative n too (P(n) - P(n-1) = n^2).
std::int64_t sum_squares(std::int64_t n) { return n * (n + 1) * (2 * n + 1) / 6; }

// Largest m >= 0 with m^2 <= q (q >= 0), exact despite sqrt rounding.
std::int64_t floor_sqrt(double q) {
  auto m = static_cast<std::int64_t>(std::sqrt(q));
  while (m > 0 && static_cast<double>(m) * m > q) --m;
  while (static_cast<double>(m + 1) * (m + 1) <= q) ++m;
  return m;
}

// floor(a / 2) and ceil(a / 2) for signed a.
std::int64_t floor_half(std::int64_t a) { return a >= 0 ? a / 2 : -((-a + 1) / 2); }
std::int64_t ceil_half(std::int64_t a) { return -floor_half(-a); }

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

// Normal from the moments: minor axis of the covariance, oriented along n_e.
Eigen::Vector2d covariance_normal(const Moments& mo, const Eigen::Vector2d& trivial) {
  if (mo.n < 3) return trivial;
  // n^2 * covariance, exact in 128-bit integers, then rounded once.
  const __int128 n = mo.n;
  const double cxx = static_cast<double>(n * mo.sxx - static_cast<__int128>(mo.sx) * mo.sx);
  const double cyy = static_cast<double>(n * mo.syy - static_cast<__int128>(mo.sy) * mo.sy);
  const double cxy = static_cast<double>(n * mo.sxy - static_cast<__int128>(mo.sx) * mo.sy);
  if (cxy == 0 && cxx == cyy) return trivial;  // isotropic: no preferred direction
  const double major = 0.5 * std::atan2(2.0 * cxy, cxx - cyy);
  Eigen::Vector2d normal(-std::sin(major), std::cos(major));
  if (normal.dot(trivial) < 0) normal = -normal;
  return normal;
}

}  // namespace

LinelNormals ii_normals(const DigitalSet& set, const ContourSet& contours, const IINormalOptions& options) {
  require_positive("ii_normals: k_R", options.k_R);
  const double h = set.h();
  const double R = options.k_R * std::cbrt(h);
  const double rho = R / h;
  if (!set.empty()) {
    std::int64_t imin = INT64_MAX, imax = INT64_MIN;
    for (std::int32_t j = set.row_begin(); j < set.row_end(); ++j)
      if (set.row_runs_begin(j) != set.row_runs_end(j))
        imin = std::min<std::int64_t>(imin, set.row_runs_begin(j)->begin),
        imax = std::max<std::int64_t>(imax, (set.row_runs_end(j) - 1)->end);
    const double diameter = std::hypot(static_cast<double>(imax - imin), set.row_end() - set.row_begin());
    if (rho > diameter) {
      std::ostringstream msg;
      msg << "ii_normals: the disk radius R = k_R * h^(1/3) = " << R << " exceeds the whole set ("
          << "diameter " << diameter * h << "): the normals would carry no information; use k_R < "
          << options.k_R * diameter / rho;
      throw Error(msg.str());
    }
  }
  const std::vector<std::int64_t> chord = chord_table(rho);
  LinelNormals normals(contours.contours.size());
  for (std::size_t c = 0; c < contours.contours.size(); ++c) {
    const Contour& contour = contours.contours[c];
    const auto n = static_cast<std::int64_t>(contour.size());
    Eigen::MatrixX2d& out = normals[c];
    out.resize(n, 2);
#pragma omp parallel for schedule(dynamic, 256)
    for (std::int64_t i = 0; i < n; ++i) {
      const Eigen::Vector2i d = step_vector(contour.steps[i]);
      const Eigen::Vector2i& v = contour.pointels[i];
      // Linel midpoint in doubled pixel coordinates: pointel (p, q) is at (2p + 1, 2q + 1).
      const std::int64_t X = 2 * static_cast<std::int64_t>(v.x()) + 1 + d.x();
      const std::int64_t Y = 2 * static_cast<std::int64_t>(v.y()) + 1 + d.y();
      out.row(i) = covariance_normal(disk_moments(set, X, Y, chord), linel_normal(contour.steps[i])).transpose();
    }
  }
  return normals;
}

LinelNormals exact_normals(const Shape& shape, const ContourSet& contours) {
  LinelNormals normals(contours.contours.size());
  for (std::size_t c = 0; c < contours.contours.size(); ++c) {
    const auto n = static_cast<std::int64_t>(contours.contours[c].size());
    normals[c].resize(n, 2);
#pragma omp parallel for schedule(dynamic, 256)
    for (std::int64_t i = 0; i < n; ++i) {
      const double theta = shape.closest_parameter(contours.linel_midpoint(c, i));
      normals[c].row(i) = shape.outward_normal(theta).transpose();
    }
  }
  return normals;
}

}  // namespace digilap
