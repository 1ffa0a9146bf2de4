#include "digilap/surface/normals.hpp"
#include "digilap/core/constants.hpp"

#include "digilap/core/error.hpp"
#include "digilap/surface/length_scale.hpp"
#include "core/lattice.hpp"
#include "ball_moments.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
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
Eigen::Vector3d covariance_normal(const Moments& mo, const Eigen::Vector3d& centre_offset, const Eigen::Vector3d& trivial,
                                  const Eigen::Matrix3d& ball_anisotropy) {
  if (mo.n < 4) return trivial;
  const __int128 n = mo.n;
  Eigen::Matrix3d c;  // n^2 times the covariance
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b)
      c(a, b) = c(b, a) = static_cast<double>(n * mo.ss[a][b] - static_cast<__int128>(mo.s[a]) * mo.s[b]);
  // Without the digital ball's own direction. Its covariance about the centre is c I + D, with D
  // along or across the surfel's axis and changing sign with rho; D tilts both the covariance of
  // the set's half of the ball and its centroid's offset d, and so the normal, towards each
  // tangent u by -(1 - |d|^2 / c) u.D.n / |d|^2 (to first order), which swung the area (the sum of
  // mu = h^2 |n . e|) by +-3% from one rho to the next. Removing alpha D with alpha = 1 - |d|^2 / c
  // of the round half ball, 1 - (3 rho / 8)^2 / (rho^2 / 5) = 19 / 64, cancels that tilt: the
  // area of the sphere at h = 0.03 stays within +-0.4% for every rho in 3 ... 8 voxels
  // (docs/accuracy.md, "The digital ball's anisotropy"). The measured |d|^2 instead of the
  // constant did worse (it is noisy from one surfel to the next).
  constexpr double kAnisotropyWeight = 19.0 / 64.0;
  const Eigen::Matrix3d shift = kAnisotropyWeight * static_cast<double>(mo.n) * static_cast<double>(mo.n) * ball_anisotropy;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(c);
  // First order only holds while the shift is small against the gap it perturbs: the least
  // eigenvalue's distance to the next (about 17 times the shift on a smooth surface, rho >= 3).
  // Across a tube one or two voxels thick the two least eigenvalues are nearly equal, and the
  // shift would pick between them, turning normals along the tube's surface (mu = 0: on the 2 mm
  // atlas's corticospinal tract 27 such surfels instead of 11, its area 21% smaller). So the
  // correction fades out from a gap of 8 shifts to 4.
  constexpr double kGapFull = 8.0, kGapNone = 4.0;
  const double size = shift.cwiseAbs().maxCoeff();
  if (size > 0) {
    const double gap = (eig.eigenvalues()[1] - eig.eigenvalues()[0]) / size;
    const double weight = std::clamp((gap - kGapNone) / (kGapFull - kGapNone), 0.0, 1.0);
    if (weight > 0) eig.compute(c - weight * shift);
  }
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
Eigen::MatrixX3d ii_normals_at(const VoxelSet& set, const SurfelSet& surfels, double rho, bool remove_ball_anisotropy) {
  Eigen::MatrixX3d normals(static_cast<Eigen::Index>(surfels.size()), 3);
  const BallRows ball(rho);
  std::array<Eigen::Matrix3d, 3> anisotropy;
  for (int axis = 0; axis < 3; ++axis)
    anisotropy[static_cast<std::size_t>(axis)] = remove_ball_anisotropy ? ball.anisotropy(axis) : Eigen::Matrix3d::Zero();
#pragma omp parallel for schedule(dynamic, 256)
  for (std::size_t s = 0; s < surfels.size(); ++s) {
    const Surfel& f = surfels.surfels[s];
    const auto c = doubled_centre(f);
    const Eigen::Vector3d offset(0.5 * static_cast<double>(c[0]) - static_cast<double>(floor_half(c[0])),
                                 0.5 * static_cast<double>(c[1]) - static_cast<double>(floor_half(c[1])),
                                 0.5 * static_cast<double>(c[2]) - static_cast<double>(floor_half(c[2])));
    normals.row(static_cast<Eigen::Index>(s)) =
        covariance_normal(ball.moments(set, f), offset, surfels.trivial_normal(s), anisotropy[static_cast<std::size_t>(f.axis)]).transpose();
  }
  return normals;
}
}  // namespace detail

double ii_ball_radius(double k_R, double h, double l) {
  if (k_R != 0) require_positive("ii_ball_radius: k_R", k_R);
  require_positive("ii_ball_radius: h", h);
  require_positive("ii_ball_radius: l", l);
  const double unit = std::cbrt(h) * std::pow(l, 2.0 / 3.0);  // R for k_R = 1
  if (k_R != 0) return k_R * unit;
  // The adaptive default (docs/accuracy.md): k_R = 1.5 on thick surfaces (the torus's worst
  // eigenvalue 0.92 -> 0.39% at h = 0.05, 0.18 -> 0.13% at 0.0125), k_R = 1 where a wider ball
  // would reach across a thin part (l / h below 8: every label of the atlases).
  constexpr double kSmallest = 1.0, kLargest = 1.5, kThicknessFraction = 0.5;
  return std::max(kSmallest * unit, std::min(kLargest * unit, kThicknessFraction * l));
}

SurfelNormals ii_normals(const VoxelSet& set, const SurfelSet& surfels, const SurfaceNormalOptions& o) {
  if (o.k_R != 0) require_positive("ii_normals: k_R", o.k_R);
  const double h = set.h();
  SurfelNormals out;
  set_length_scale("ii_normals", set, surfels, o, out);
  out.radius = ii_ball_radius(o.k_R, h, out.length_scale);
  const double rho = out.radius / h;
  const double diameter = 2 * std::cbrt(3.0 * static_cast<double>(set.voxel_count()) / (4 * kPi)) + 2;
  if (!set.empty() && rho > 2 * diameter) {
    std::ostringstream msg;
    msg << "ii_normals: the ball radius R = " << out.radius << " is wider than the whole set (about " << diameter * h
        << " across): the normals would carry no information; use a smaller k_R";
    throw Error(msg.str());
  }
  out.normals = detail::ii_normals_at(set, surfels, rho, o.remove_ball_anisotropy);
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
