#include "digilap/curve/length_scale.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "disk_moments.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace digilap {
inline namespace curve {

namespace {
constexpr double kFloorPixels = 4.0;
constexpr std::size_t kMaxSamples = 20000;
constexpr int kRounds = 3;
}  // namespace

LengthScale length_scale(const DigitalSet& set, const ContourSet& contours, const LengthScaleOptions& o) {
  require_positive("length_scale: k_R", o.k_R);
  if (!(o.quantile > 0 && o.quantile < 1))
    throw Error("length_scale: the quantile must be in (0, 1), got " + std::to_string(o.quantile));
  const double h = set.h();
  // Upper bound: the radius of the disc with the area of the largest contour (exact area from
  // the pointel polygon, in pixels).
  double size_px = 0;
  std::size_t total = 0;
  for (const Contour& c : contours.contours) {
    size_px = std::max(size_px, std::sqrt(0.5 * std::abs(static_cast<double>(c.twice_signed_area())) / kPi));
    total += c.size();
  }
  LengthScale out;
  // The floor yields to the size: an object of a few pixels has l = its own radius.
  const double floor_px = std::min(kFloorPixels, std::max(size_px, 0.5));
  out.floor = floor_px * h;
  out.size_bound = size_px * h;
  double length_px = std::max(floor_px, size_px);
  if (total == 0) {
    out.length = kFloorPixels * h;
    return out;
  }
  // The linels sampled: every stride-th one along the contours, in contour order.
  const std::size_t stride = (total + kMaxSamples - 1) / kMaxSamples;
  std::vector<std::pair<std::size_t, std::size_t>> sampled;
  std::size_t k = 0;
  for (std::size_t c = 0; c < contours.contours.size(); ++c)
    for (std::size_t i = 0; i < contours.contours[c].size(); ++i, ++k)
      if (k % stride == 0) sampled.emplace_back(c, i);
  out.samples = sampled.size();
  std::vector<double> radius(sampled.size());
  for (int round = 0; round < kRounds; ++round) {
    // The disk's radius in pixels, at most the size bound (a disk wider than the shape would
    // measure the shape's area, not its boundary's bending).
    const double rho = std::min(o.k_R * std::pow(length_px, 2.0 / 3.0), std::max(size_px, 1.0));
    const std::vector<std::int64_t> chord = detail::chord_table(rho);
#pragma omp parallel for schedule(dynamic, 64)
    for (std::size_t s = 0; s < sampled.size(); ++s) {
      const Contour& contour = contours.contours[sampled[s].first];
      const std::size_t i = sampled[s].second;
      const Eigen::Vector2i d = step_vector(contour.steps[i]);
      const Eigen::Vector2i& v = contour.pointels[i];
      const std::int64_t X = 2 * static_cast<std::int64_t>(v.x()) + 1 + d.x();
      const std::int64_t Y = 2 * static_cast<std::int64_t>(v.y()) + 1 + d.y();
      const double area = static_cast<double>(detail::disk_moments(set, X, Y, chord).n);
      // II curvature in 2D [Pottmann et al. 2007]: a straight boundary fills half the disk.
      const double kappa = 3 * kPi / (2 * rho) - 3 * area / (rho * rho * rho);
      radius[s] = kappa != 0 ? 1 / std::abs(kappa) : INFINITY;
    }
    // Each contour's quantile, within its own bounds; then the median over the contours,
    // weighted by their linels: a small contour (a speck, a cell among many) counts for its
    // share of the boundary, and cannot pull the quantile of a large one.
    out.per_contour.assign(contours.contours.size(), 0.0);
    std::vector<std::pair<double, std::size_t>> weighted;  // (l_c in pixels, linels of c)
    for (std::size_t first = 0; first < sampled.size();) {
      const std::size_t c = sampled[first].first;
      std::size_t last = first;
      while (last < sampled.size() && sampled[last].first == c) ++last;
      std::vector<double> own(radius.begin() + static_cast<std::ptrdiff_t>(first), radius.begin() + static_cast<std::ptrdiff_t>(last));
      const auto q = static_cast<std::ptrdiff_t>(o.quantile * static_cast<double>(own.size() - 1));
      std::nth_element(own.begin(), own.begin() + q, own.end());
      const double own_size = std::sqrt(0.5 * std::abs(static_cast<double>(contours.contours[c].twice_signed_area())) / kPi);
      const double own_floor = std::min(kFloorPixels, std::max(own_size, 0.5));
      const double l_c = std::clamp(own[static_cast<std::size_t>(q)], own_floor, std::max(own_floor, own_size));
      out.per_contour[c] = l_c * h;
      weighted.emplace_back(l_c, contours.contours[c].size());
      first = last;
    }
    std::sort(weighted.begin(), weighted.end());
    std::size_t seen = 0;
    for (const auto& [l_c, linels] : weighted) {
      seen += linels;
      length_px = l_c;
      if (2 * seen >= total) break;
    }
  }
  out.length = length_px * h;
  return out;
}

}  // namespace curve
}  // namespace digilap
