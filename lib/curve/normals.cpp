#include "digilap/curve/normals.hpp"

#include "digilap/core/error.hpp"
#include "digilap/curve/length_scale.hpp"
#include "disk_moments.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <vector>
#include <sstream>

namespace digilap {
inline namespace curve {

namespace {

// Normal from the moments: minor axis of the covariance, oriented along n_e.
Eigen::Vector2d covariance_normal(const detail::Moments& mo, const Eigen::Vector2d& trivial) {
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

// Per-contour length scales, l where a contour was too short to be sampled (l_c = 0).
std::vector<double> with_fallback(std::vector<double> per_contour, double l) {
  for (double& l_c : per_contour)
    if (!(l_c > 0)) l_c = l;
  return per_contour;
}

}  // namespace

LinelNormals ii_normals(const DigitalSet& set, const ContourSet& contours, const IINormalOptions& options) {
  require_positive("ii_normals: k_R", options.k_R);
  const double h = set.h();
  double l = options.length_scale;
  std::vector<double> per_contour;
  if (l != 0) {
    require_positive("ii_normals: length_scale", l);
  } else {
    const LengthScale measured = length_scale(set, contours, {LengthScaleOptions{}.k_R, options.length_quantile});
    l = measured.length;
    per_contour = with_fallback(measured.per_contour, l);
  }
  const double R = options.k_R * std::cbrt(h) * std::pow(l, 2.0 / 3.0);
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
      msg << "ii_normals: the disk radius R = k_R h^(1/3) l^(2/3) = " << R << " exceeds the whole set ("
          << "diameter " << diameter * h << "): the normals would carry no information; use k_R < "
          << options.k_R * diameter / rho;
      throw Error(msg.str());
    }
  }
  const std::vector<std::int64_t> chord = detail::chord_table(rho);
  LinelNormals normals(contours.contours.size());
  normals.length_scale = l;
  normals.radius = R;
  normals.contour_length_scales = std::move(per_contour);
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
      out.row(i) = covariance_normal(detail::disk_moments(set, X, Y, chord), linel_normal(contour.steps[i])).transpose();
    }
  }
  return normals;
}

LinelNormals exact_normals(const Shape& shape, const ContourSet& contours, double l) {
  LinelNormals normals(contours.contours.size());
  if (l != 0) {
    require_positive("exact_normals: length_scale", l);
  } else {
    const LengthScale measured = length_scale(digitize(shape, contours.h), contours);
    l = measured.length;
    normals.contour_length_scales = with_fallback(measured.per_contour, l);
  }
  normals.length_scale = l;
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

}  // namespace curve
}  // namespace digilap
