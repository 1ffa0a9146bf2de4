#include "digilap/surface/normals.hpp"

#include "digilap/error.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace digilap::surface {

namespace {
constexpr double kPi = 3.14159265358979323846;

std::int64_t floor_half(std::int64_t a) { return a >= 0 ? a / 2 : -((-a + 1) / 2); }
std::int64_t ceil_half(std::int64_t a) { return -floor_half(-a); }
std::int64_t floor_sqrt(double q) {
  if (q < 0) return -1;
  auto m = static_cast<std::int64_t>(std::sqrt(q));
  while (m > 0 && static_cast<double>(m) * m > q) --m;
  while (static_cast<double>(m + 1) * (m + 1) <= q) ++m;
  return m;
}
std::int64_t sum_squares(std::int64_t n) { return n * (n + 1) * (2 * n + 1) / 6; }

// Exact moments of the voxel centres in a ball, relative to a voxel near its centre.
struct Moments {
  std::int64_t n = 0, s[3] = {0, 0, 0}, ss[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
};

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
      const Run* b = set.row_begin(static_cast<std::int32_t>(j), static_cast<std::int32_t>(k));
      const Run* e = set.row_end(static_cast<std::int32_t>(j), static_cast<std::int32_t>(k));
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

// Normal from the moments: the covariance's least eigenvector, oriented from the voxels'
// centroid towards the surfel's centre (the trivial normal when that is undecided).
Eigen::Vector3d covariance_normal(const Moments& mo, const Eigen::Vector3d& centre_offset, const Eigen::Vector3d& trivial) {
  if (mo.n < 4) return trivial;
  const __int128 n = mo.n;
  Eigen::Matrix3d c;
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b)
      c(a, b) = c(b, a) = static_cast<double>(n * mo.ss[a][b] - static_cast<__int128>(mo.s[a]) * mo.s[b]);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(c);
  Eigen::Vector3d normal = eig.eigenvectors().col(0);
  const Eigen::Vector3d centroid(static_cast<double>(mo.s[0]) / mo.n, static_cast<double>(mo.s[1]) / mo.n, static_cast<double>(mo.s[2]) / mo.n);
  const double side = normal.dot(centre_offset - centroid);
  if (side < 0 || (side == 0 && normal.dot(trivial) < 0)) normal = -normal;
  return normal;
}

// l measured on the set (see SurfaceNormalOptions), in voxels.
double measure_length_scale(const VoxelSet& set, const SurfelSet& surfels) {
  constexpr double kFloor = 4.0;
  constexpr std::size_t kMaxSamples = 20000;
  const double size = std::cbrt(3.0 * static_cast<double>(set.voxel_count()) / (4 * kPi));
  double l = std::max(kFloor, size);
  const std::size_t stride = (surfels.size() + kMaxSamples - 1) / kMaxSamples;
  std::vector<std::size_t> sampled;
  for (std::size_t s = 0; s < surfels.size(); s += std::max<std::size_t>(stride, 1)) sampled.push_back(s);
  if (sampled.empty()) return kFloor;
  std::vector<double> radius(sampled.size());
  for (int round = 0; round < 3; ++round) {
    const double rho = std::min(2.0 * std::pow(l, 2.0 / 3.0), std::max(size, 1.0));
#pragma omp parallel for schedule(dynamic, 64)
    for (std::size_t q = 0; q < sampled.size(); ++q) {
      const auto c = doubled_centre(surfels.surfels[sampled[q]]);
      const double volume = static_cast<double>(ball_moments(set, c[0], c[1], c[2], rho).n);
      const double H = 8 / (3 * rho) - 4 * volume / (kPi * rho * rho * rho * rho);
      radius[q] = H != 0 ? 1 / std::abs(H) : INFINITY;
    }
    std::vector<double> sorted = radius;
    const auto at = static_cast<std::ptrdiff_t>(0.02 * static_cast<double>(sorted.size() - 1));
    std::nth_element(sorted.begin(), sorted.begin() + at, sorted.end());
    l = std::clamp(sorted[static_cast<std::size_t>(at)], std::min(kFloor, size), std::max(kFloor, size));
  }
  return l;
}

}  // namespace

SurfelNormals ii_normals(const VoxelSet& set, const SurfelSet& surfels, const SurfaceNormalOptions& o) {
  require_positive("ii_normals: k_R", o.k_R);
  const double h = set.h();
  SurfelNormals out;
  out.length_scale = o.length_scale;
  if (o.length_scale != 0) require_positive("ii_normals: length_scale", o.length_scale);
  else out.length_scale = measure_length_scale(set, surfels) * h;
  out.radius = o.k_R * std::cbrt(h) * std::pow(out.length_scale, 2.0 / 3.0);
  const double rho = out.radius / h;
  const double diameter = 2 * std::cbrt(3.0 * static_cast<double>(set.voxel_count()) / (4 * kPi)) + 2;
  if (!set.empty() && rho > 2 * diameter) {
    std::ostringstream msg;
    msg << "ii_normals: the ball radius R = " << out.radius << " is wider than the whole set (about " << diameter * h
        << " across): the normals would carry no information; use a smaller k_R";
    throw Error(msg.str());
  }
  out.normals.resize(static_cast<Eigen::Index>(surfels.size()), 3);
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t s = 0; s < surfels.size(); ++s) {
    const Surfel& f = surfels.surfels[s];
    const auto c = doubled_centre(f);
    const Eigen::Vector3d offset(0.5 * static_cast<double>(c[0]) - static_cast<double>(floor_half(c[0])),
                                 0.5 * static_cast<double>(c[1]) - static_cast<double>(floor_half(c[1])),
                                 0.5 * static_cast<double>(c[2]) - static_cast<double>(floor_half(c[2])));
    out.normals.row(static_cast<Eigen::Index>(s)) =
        covariance_normal(ball_moments(set, c[0], c[1], c[2], rho), offset, surfels.trivial_normal(s)).transpose();
  }
  return out;
}

SurfelNormals exact_normals(const Surface& surface, const SurfelSet& surfels, double length_scale) {
  require_positive("exact_normals: length_scale", length_scale);
  SurfelNormals out;
  out.length_scale = length_scale;
  out.normals.resize(static_cast<Eigen::Index>(surfels.size()), 3);
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t s = 0; s < surfels.size(); ++s)
    out.normals.row(static_cast<Eigen::Index>(s)) = surface.normal(surface.closest_point(surfels.centre(s))).transpose();
  return out;
}

}  // namespace digilap::surface
