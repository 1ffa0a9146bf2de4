#include "ball_moments.hpp"

#include "core/lattice.hpp"

#include <algorithm>

namespace digilap::surface::detail {

using digilap::detail::ceil_half;
using digilap::detail::floor_half;
using digilap::detail::floor_sqrt;
using digilap::detail::sum_squares;

namespace {

// Calls row(j, k, lo, hi) for each (y, z) row of the ball of radius rho (voxels) around
// (X, Y, Z) / 2 that holds voxel centres, with its voxels lo ... hi.
template <typename RowFunction>
void for_ball_rows(std::int64_t X, std::int64_t Y, std::int64_t Z, double rho, const RowFunction& row) {
  const double r2 = 4 * rho * rho;
  const std::int64_t m = floor_sqrt(r2);
  for (std::int64_t k = ceil_half(Z - m); k <= floor_half(Z + m); ++k) {
    const std::int64_t dz2 = (2 * k - Z) * (2 * k - Z);
    const std::int64_t my = floor_sqrt(r2 - static_cast<double>(dz2));
    for (std::int64_t j = ceil_half(Y - my); j <= floor_half(Y + my); ++j) {
      const std::int64_t mx = floor_sqrt(r2 - static_cast<double>(dz2 + (2 * j - Y) * (2 * j - Y)));
      if (mx >= 0) row(j, k, ceil_half(X - mx), floor_half(X + mx));
    }
  }
}

// Calls part(a, c) for each run of the set's voxels a ... c (a <= c) within lo ... hi of row (j, k).
template <typename RunFunction>
void for_runs_in_row(const VoxelSet& set, std::int64_t j, std::int64_t k, std::int64_t lo, std::int64_t hi, const RunFunction& part) {
  const Run* b = set.row_runs_begin(static_cast<std::int32_t>(j), static_cast<std::int32_t>(k));
  const Run* e = set.row_runs_end(static_cast<std::int32_t>(j), static_cast<std::int32_t>(k));
  for (const Run* r = std::upper_bound(b, e, lo, [](std::int64_t v, const Run& run) { return v < run.end; }); r != e && r->begin <= hi; ++r) {
    const std::int64_t a = std::max<std::int64_t>(lo, r->begin), c = std::min<std::int64_t>(hi, r->end - 1);
    if (a <= c) part(a, c);
  }
}

}  // namespace

BallRows::BallRows(double rho) : rho_(rho) {
  // Around the voxel (i0, j0, k0) = (0, 0, 0), the centre moved by half a voxel along the axis:
  // the doubled centre (1, 0, 0), (0, 1, 0) or (0, 0, 1). floor_half and ceil_half shift by
  // whole voxels, so another voxel's rows are these moved by (i0, j0, k0).
  for (int axis = 0; axis < 3; ++axis) {
    const std::int64_t X = axis == 0, Y = axis == 1, Z = axis == 2;
    for_ball_rows(X, Y, Z, rho, [&](std::int64_t j, std::int64_t k, std::int64_t lo, std::int64_t hi) {
      rows_[static_cast<std::size_t>(axis)].push_back(
          {static_cast<std::int32_t>(j), static_cast<std::int32_t>(k), static_cast<std::int32_t>(lo), static_cast<std::int32_t>(hi)});
    });
    // The whole ball's covariance about its centre (X, Y, Z) / 2, summed row by row.
    double n = 0;
    Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
    for (const Row& r : rows_[static_cast<std::size_t>(axis)])
      for (std::int64_t i = r.lo; i <= r.hi; ++i) {
        const Eigen::Vector3d p(static_cast<double>(i) - 0.5 * static_cast<double>(X), r.dj - 0.5 * static_cast<double>(Y),
                                r.dk - 0.5 * static_cast<double>(Z));
        second += p * p.transpose(), n += 1;
      }
    const Eigen::Matrix3d covariance = n > 0 ? Eigen::Matrix3d(second / n) : Eigen::Matrix3d::Zero();
    anisotropy_[static_cast<std::size_t>(axis)] = covariance - covariance.trace() / 3 * Eigen::Matrix3d::Identity();
  }
}

template <typename RowFunction>
void BallRows::for_rows(const Surfel& f, const RowFunction& row) const {
  // The voxel whose rows are tabulated: floor_half of the doubled centre, which is f's voxel,
  // or its neighbour below when the surfel is on the voxel's lower face.
  std::int64_t base[3] = {f.voxel[0], f.voxel[1], f.voxel[2]};
  if (f.sign < 0) base[f.axis] -= 1;
  for (const Row& r : rows_[static_cast<std::size_t>(f.axis)])
    row(base[1] + r.dj, base[2] + r.dk, base[0] + r.lo, base[0] + r.hi, base);
}

// Each row meets the set in a few runs, whose moments have closed forms (relative to the base
// voxel).
Moments BallRows::moments(const VoxelSet& set, const Surfel& f) const {
  Moments mo;
  for_rows(f, [&](std::int64_t j, std::int64_t k, std::int64_t lo, std::int64_t hi, const std::int64_t* base) {
    const std::int64_t dj = j - base[1], dk = k - base[2];
    for_runs_in_row(set, j, k, lo, hi, [&](std::int64_t first, std::int64_t last) {
      const std::int64_t a = first - base[0], c = last - base[0];
      const std::int64_t count = c - a + 1, sx = (a + c) * count / 2, sxx = sum_squares(c) - sum_squares(a - 1);
      mo.n += count;
      mo.s[0] += sx, mo.s[1] += dj * count, mo.s[2] += dk * count;
      mo.ss[0][0] += sxx, mo.ss[1][1] += dj * dj * count, mo.ss[2][2] += dk * dk * count;
      mo.ss[0][1] += dj * sx, mo.ss[0][2] += dk * sx, mo.ss[1][2] += dj * dk * count;
    });
  });
  return mo;
}

std::int64_t BallRows::count(const VoxelSet& set, const Surfel& f) const {
  std::int64_t n = 0;
  for_rows(f, [&](std::int64_t j, std::int64_t k, std::int64_t lo, std::int64_t hi, const std::int64_t*) {
    for_runs_in_row(set, j, k, lo, hi, [&](std::int64_t first, std::int64_t last) { n += last - first + 1; });
  });
  return n;
}

// Doubled coordinates of a surfel's centre.
Eigen::Matrix<std::int64_t, 3, 1> doubled_centre(const Surfel& f) {
  Eigen::Matrix<std::int64_t, 3, 1> c = 2 * f.voxel.cast<std::int64_t>();
  c[f.axis] += f.sign;
  return c;
}

}  // namespace digilap::surface::detail
