#include "digilap/surface/normals.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "digilap/surface/length_scale.hpp"
#include "core/lattice.hpp"
#include "ball_moments.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace digilap::surface {

namespace {
using detail::BallRows;
using detail::doubled_centre;
using detail::Moments;
using digilap::detail::floor_half;

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

// l (and each surface's l_c) given or measured on the set: the same for II and exact normals.
void set_length_scale(const char* who, const VoxelSet& set, const SurfelSet& surfels, const SurfaceNormalOptions& o,
                      SurfelNormals& out) {
  out.length_scale = o.length_scale;
  if (o.length_scale != 0) {
    require_positive(std::string(who) + ": length_scale", o.length_scale);
    return;
  }
  const LengthScale measured = length_scale(set, surfels, {LengthScaleOptions{}.k_R, o.length_quantile});
  out.length_scale = measured.length;
  out.surface_length_scales = measured.per_contour;
  for (double& l_c : out.surface_length_scales)  // a surface too small to be sampled: the set's l
    if (!(l_c > 0)) l_c = out.length_scale;
}
}  // namespace

namespace detail {
Eigen::MatrixX3d ii_normals_at(const VoxelSet& set, const SurfelSet& surfels, double rho) {
  Eigen::MatrixX3d normals(static_cast<Eigen::Index>(surfels.size()), 3);
  const BallRows ball(rho);
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t s = 0; s < surfels.size(); ++s) {
    const Surfel& f = surfels.surfels[s];
    const auto c = doubled_centre(f);
    const Eigen::Vector3d offset(0.5 * static_cast<double>(c[0]) - static_cast<double>(floor_half(c[0])),
                                 0.5 * static_cast<double>(c[1]) - static_cast<double>(floor_half(c[1])),
                                 0.5 * static_cast<double>(c[2]) - static_cast<double>(floor_half(c[2])));
    normals.row(static_cast<Eigen::Index>(s)) =
        covariance_normal(ball.moments(set, f), offset, surfels.trivial_normal(s)).transpose();
  }
  return normals;
}
}  // namespace detail

SurfelNormals ii_normals(const VoxelSet& set, const SurfelSet& surfels, const SurfaceNormalOptions& o) {
  require_positive("ii_normals: k_R", o.k_R);
  const double h = set.h();
  SurfelNormals out;
  set_length_scale("ii_normals", set, surfels, o, out);
  out.radius = o.k_R * std::cbrt(h) * std::pow(out.length_scale, 2.0 / 3.0);
  const double rho = out.radius / h;
  const double diameter = 2 * std::cbrt(3.0 * static_cast<double>(set.voxel_count()) / (4 * kPi)) + 2;
  if (!set.empty() && rho > 2 * diameter) {
    std::ostringstream msg;
    msg << "ii_normals: the ball radius R = " << out.radius << " is wider than the whole set (about " << diameter * h
        << " across): the normals would carry no information; use a smaller k_R";
    throw Error(msg.str());
  }
  out.normals = detail::ii_normals_at(set, surfels, rho);
  return out;
}

SurfelNormals exact_normals(const Surface& surface, const SurfelSet& surfels, double length_scale) {
  SurfaceNormalOptions o;
  o.length_scale = length_scale;
  // l given: the set is not read (set_length_scale checks l), so an empty one will do.
  return exact_normals(surface, length_scale != 0 ? VoxelSet(surfels.h) : digitize(surface, surfels.h), surfels, o);
}

SurfelNormals exact_normals(const Surface& surface, const VoxelSet& set, const SurfelSet& surfels, const SurfaceNormalOptions& o) {
  SurfelNormals out;
  set_length_scale("exact_normals", set, surfels, o, out);
  out.normals.resize(static_cast<Eigen::Index>(surfels.size()), 3);
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t s = 0; s < surfels.size(); ++s)
    out.normals.row(static_cast<Eigen::Index>(s)) = surface.normal(surface.closest_point(surfels.centre(s))).transpose();
  return out;
}

}  // namespace digilap::surface
