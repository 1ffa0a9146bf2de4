#include "digilap/surface/length_scale.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "ball_moments.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace digilap::surface {

namespace {
constexpr double kFloorVoxels = 4.0;
constexpr std::size_t kMaxSamples = 20000;
constexpr int kRounds = 3;

// The surfels sampled: all up to kMaxSamples, else those whose position relative to the centre
// of the surfels' bounding box, as sorted absolute doubled coordinates (invariant under the 48
// signed permutations of the axes), hashes to 0 modulo the stride.
std::vector<std::size_t> sampled_surfels(const SurfelSet& surfels) {
  const std::size_t n = surfels.size();
  std::vector<std::size_t> sampled;
  if (n <= kMaxSamples) {
    sampled.resize(n);
    for (std::size_t s = 0; s < n; ++s) sampled[s] = s;
    return sampled;
  }
  std::array<std::int64_t, 3> lo, hi;
  lo.fill(std::numeric_limits<std::int64_t>::max()), hi.fill(std::numeric_limits<std::int64_t>::min());
  for (const Surfel& f : surfels.surfels) {
    const auto c = detail::doubled_centre(f);
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], c[a]), hi[a] = std::max(hi[a], c[a]);
  }
  const std::uint64_t stride = (n + kMaxSamples - 1) / kMaxSamples;
  for (std::size_t s = 0; s < n; ++s) {
    const auto c = detail::doubled_centre(surfels.surfels[s]);
    std::array<std::uint64_t, 3> r;
    for (int a = 0; a < 3; ++a) r[a] = static_cast<std::uint64_t>(std::abs(2 * c[a] - lo[a] - hi[a]));
    std::sort(r.begin(), r.end());
    std::uint64_t key = r[0] * 0x9E3779B97F4A7C15ull ^ (r[1] + 0x632BE59BD9B4E019ull) * 0xC2B2AE3D27D4EB4Full ^ r[2] * 0x165667B19E3779F9ull;
    key ^= key >> 29, key *= 0xBF58476D1CE4E5B9ull, key ^= key >> 32;  // mixed, so that the residue is uniform
    if (key % stride == 0) sampled.push_back(s);
  }
  return sampled;
}
}  // namespace

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
    const double voxels = 0.5 * static_cast<double>(surface::detail::twice_enclosed_voxels(surfels, offset[c], offset[c + 1]));
    size[c] = std::cbrt(3.0 * std::abs(voxels) / (4 * kPi));
    largest = std::max(largest, size[c]);
  }
  LengthScale out;
  out.floor = std::min(kFloorVoxels, largest) * h;
  out.size_bound = largest * h;
  out.per_contour.assign(surfaces, 0.0);
  const std::vector<std::size_t> sampled = sampled_surfels(surfels);
  out.samples = sampled.size();
  if (sampled.empty()) {
    out.length = kFloorVoxels * h;
    return out;
  }
  double l = std::max(kFloorVoxels, largest);
  std::vector<double> radius(sampled.size());
  for (int round = 0; round < kRounds; ++round) {
    // The ball's radius in voxels, at most the largest surface's size (a ball wider than the
    // object would measure its volume, not its boundary's bending).
    const double rho = std::min(o.k_R * std::pow(l, 2.0 / 3.0), std::max(largest, 1.0));
#pragma omp parallel for schedule(dynamic, 64)
    for (std::size_t q = 0; q < sampled.size(); ++q) {
      const auto c = detail::doubled_centre(surfels.surfels[sampled[q]]);
      const double volume = static_cast<double>(detail::ball_moments(set, c[0], c[1], c[2], rho).n);
      // II mean curvature [Pottmann et al. 2007]: a flat boundary fills half the ball.
      const double H = 8 / (3 * rho) - 4 * volume / (kPi * rho * rho * rho * rho);
      radius[q] = H != 0 ? 1 / std::abs(H) : INFINITY;
    }
    // Each surface's quantile within its own bounds, then the median over the surfaces weighted
    // by their surfels (the samples are in surface order).
    std::vector<std::pair<double, std::size_t>> weighted;  // (l_c in voxels, surfels of c)
    for (std::size_t first = 0, c = 0; first < sampled.size(); ++c) {
      if (sampled[first] >= offset[c + 1]) continue;
      std::size_t last = first;
      while (last < sampled.size() && sampled[last] < offset[c + 1]) ++last;
      std::vector<double> own(radius.begin() + static_cast<std::ptrdiff_t>(first), radius.begin() + static_cast<std::ptrdiff_t>(last));
      const auto at = static_cast<std::ptrdiff_t>(o.quantile * static_cast<double>(own.size() - 1));
      std::nth_element(own.begin(), own.begin() + at, own.end());
      const double l_c = std::clamp(own[static_cast<std::size_t>(at)], std::min(kFloorVoxels, size[c]), std::max(kFloorVoxels, size[c]));
      out.per_contour[c] = l_c * h;
      weighted.emplace_back(l_c, offset[c + 1] - offset[c]);
      first = last;
    }
    std::sort(weighted.begin(), weighted.end());
    std::size_t total = 0, seen = 0;
    for (const auto& w : weighted) total += w.second;
    for (const auto& [l_c, count] : weighted) {
      seen += count;
      l = l_c;
      if (2 * seen >= total) break;
    }
  }
  out.length = l * h;
  return out;
}

}  // namespace digilap::surface
