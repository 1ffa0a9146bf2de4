#include "digilap/curve/measures.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>
#include <cmath>

namespace digilap {
inline namespace curve {

double ContourMeasures::geodesic_distance(std::size_t i, std::size_t j) const {
  const double d = std::abs(S[static_cast<Eigen::Index>(j)] - S[static_cast<Eigen::Index>(i)]);
  return std::min(d, length - d);
}

double Measures::total_length() const {
  double sum = 0.0;
  for (const auto& c : contours) sum += c.length;
  return sum;
}

Measures measures(const ContourSet& contours, const LinelNormals& normals) {
  if (normals.size() != contours.contours.size())
    throw Error("measures: got normals for " + std::to_string(normals.size()) + " contours, expected " +
                std::to_string(contours.contours.size()));
  Measures out;
  out.length_scale = normals.length_scale;
  out.normal_radius = normals.radius;
  out.contour_length_scales = normals.contour_length_scales;
  out.contours.resize(contours.contours.size());
  for (std::size_t c = 0; c < contours.contours.size(); ++c) {
    const Contour& contour = contours.contours[c];
    const auto n = static_cast<Eigen::Index>(contour.size());
    if (normals[c].rows() != n)
      throw Error("measures: contour " + std::to_string(c) + " has " + std::to_string(n) + " linels but " +
                  std::to_string(normals[c].rows()) + " normals");
    ContourMeasures& m = out.contours[c];
    m.linel_mu.resize(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const double dot = normals[c].row(i).dot(linel_normal(contour.steps[i]).transpose());
      if (dot <= 0) ++out.clamped;
      m.linel_mu[i] = contours.h * std::max(0.0, dot);
    }
    m.vertex_mu.resize(n);
    m.S.resize(n);
    double s = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      m.vertex_mu[i] = 0.5 * (m.linel_mu[(i + n - 1) % n] + m.linel_mu[i]);
      m.S[i] = s;
      s += m.linel_mu[i];
    }
    m.length = s;
  }
  // The deprecated name keeps its value for one release (CHANGELOG).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
  out.clamped_linels = out.clamped;
#pragma GCC diagnostic pop
  return out;
}

}  // namespace curve
}  // namespace digilap
