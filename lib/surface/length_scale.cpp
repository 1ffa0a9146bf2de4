#include "digilap/surface/length_scale.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "ball_moments.hpp"
#include "length_scale_parts.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace digilap::surface {

namespace detail {

bool sampled_for_length(const Surfel& f, std::size_t n, const std::array<std::int64_t, 3>& lo, const std::array<std::int64_t, 3>& hi) {
  if (n <= kLengthMaxSamples) return true;
  const std::uint64_t stride = (n + kLengthMaxSamples - 1) / kLengthMaxSamples;
  const auto c = doubled_centre(f);
  std::array<std::uint64_t, 3> r;
  for (int a = 0; a < 3; ++a) r[a] = static_cast<std::uint64_t>(std::abs(2 * c[a] - lo[a] - hi[a]));
  std::sort(r.begin(), r.end());
  std::uint64_t key = r[0] * 0x9E3779B97F4A7C15ull ^ (r[1] + 0x632BE59BD9B4E019ull) * 0xC2B2AE3D27D4EB4Full ^ r[2] * 0x165667B19E3779F9ull;
  key ^= key >> 29, key *= 0xBF58476D1CE4E5B9ull, key ^= key >> 32;  // mixed, so that the residue is uniform
  return key % stride == 0;
}

double equal_volume_radius(std::int64_t twice_enclosed_voxels) {
  const double voxels = 0.5 * static_cast<double>(twice_enclosed_voxels);
  return std::cbrt(3.0 * std::abs(voxels) / (4 * kPi));
}

double length_ball_radius(double k_R, double l, double largest) {
  // At most the largest surface's size: a ball wider than the object would measure its volume,
  // not its boundary's bending.
  return std::min(k_R * std::pow(l, 2.0 / 3.0), std::max(largest, 1.0));
}

double ii_radius_of_curvature(const VoxelSet& set, const Surfel& f, const BallRows& ball) {
  const double rho = ball.radius();
  const double volume = static_cast<double>(ball.count(set, f));
  // II mean curvature [Pottmann et al. 2007]: a flat boundary fills half the ball.
  const double H = 8 / (3 * rho) - 4 * volume / (kPi * rho * rho * rho * rho);
  return H != 0 ? 1 / std::abs(H) : INFINITY;
}

double length_round(const std::vector<double>& radius, const std::vector<std::size_t>& surface_of, const std::vector<double>& size,
                    const std::vector<std::size_t>& surfels, double quantile, std::vector<double>& per_surface) {
  // Each surface's quantile within its own bounds, then the median over the surfaces weighted by
  // their surfels.
  std::vector<std::vector<double>> own(size.size());
  for (std::size_t q = 0; q < radius.size(); ++q) own[surface_of[q]].push_back(radius[q]);
  std::vector<std::pair<double, std::size_t>> weighted;  // (l_c in voxels, surfels of c)
  per_surface.assign(size.size(), 0.0);
  for (std::size_t c = 0; c < own.size(); ++c) {
    if (own[c].empty()) continue;
    const auto at = static_cast<std::ptrdiff_t>(quantile * static_cast<double>(own[c].size() - 1));
    std::nth_element(own[c].begin(), own[c].begin() + at, own[c].end());
    const double l_c = std::clamp(own[c][static_cast<std::size_t>(at)], std::min(kLengthFloorVoxels, size[c]),
                                  std::max(kLengthFloorVoxels, size[c]));
    per_surface[c] = l_c;
    weighted.emplace_back(l_c, surfels[c]);
  }
  std::sort(weighted.begin(), weighted.end());
  std::size_t total = 0, seen = 0;
  for (const auto& w : weighted) total += w.second;
  double l = 0;
  for (const auto& [l_c, count] : weighted) {
    seen += count;
    l = l_c;
    if (2 * seen >= total) break;
  }
  return l;
}

}  // namespace detail

LengthScale length_scale(const VoxelSet& set, const SurfelSet& surfels, const LengthScaleOptions& o) {
  require_positive("length_scale: k_R", o.k_R);
  if (!(o.quantile > 0 && o.quantile < 1))
    throw Error("length_scale: the quantile must be in (0, 1), got " + std::to_string(o.quantile));
  const double h = set.h();
  const std::vector<std::size_t> offset = surfels.offsets();
  const std::size_t surfaces = offset.size() - 1;
  // Each surface's size bound: the radius of the ball of the volume it encloses.
  std::vector<double> size(surfaces);
  double largest = 0;
  for (std::size_t c = 0; c < surfaces; ++c) {
    size[c] = detail::equal_volume_radius(surface::detail::twice_enclosed_voxels(surfels, offset[c], offset[c + 1]));
    largest = std::max(largest, size[c]);
  }
  LengthScale out;
  out.floor = std::min(detail::kLengthFloorVoxels, largest) * h;
  out.size_bound = largest * h;
  out.per_contour.assign(surfaces, 0.0);
  std::array<std::int64_t, 3> lo, hi;
  lo.fill(std::numeric_limits<std::int64_t>::max()), hi.fill(std::numeric_limits<std::int64_t>::min());
  for (const Surfel& f : surfels.surfels) {
    const auto c = detail::doubled_centre(f);
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
  }
  std::vector<std::size_t> sampled, surface_of;
  for (std::size_t c = 0; c < surfaces; ++c)
    for (std::size_t s = offset[c]; s < offset[c + 1]; ++s)
      if (detail::sampled_for_length(surfels.surfels[s], surfels.size(), lo, hi)) sampled.push_back(s), surface_of.push_back(c);
  out.samples = sampled.size();
  if (sampled.empty()) {
    out.length = detail::kLengthFloorVoxels * h;
    return out;
  }
  std::vector<std::size_t> counts(surfaces);
  for (std::size_t c = 0; c < surfaces; ++c) counts[c] = offset[c + 1] - offset[c];
  double l = std::max(detail::kLengthFloorVoxels, largest);
  std::vector<double> radius(sampled.size()), per_surface;
  for (int round = 0; round < detail::kLengthRounds; ++round) {
    const detail::BallRows ball(detail::length_ball_radius(o.k_R, l, largest));
#pragma omp parallel for schedule(dynamic, 64)
    for (std::size_t q = 0; q < sampled.size(); ++q) radius[q] = detail::ii_radius_of_curvature(set, surfels.surfels[sampled[q]], ball);
    l = detail::length_round(radius, surface_of, size, counts, o.quantile, per_surface);
    for (std::size_t c = 0; c < surfaces; ++c) out.per_contour[c] = per_surface[c] * h;
  }
  out.length = l * h;
  return out;
}

}  // namespace digilap::surface
