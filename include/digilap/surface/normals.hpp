// digilap — normals of the surfels: Integral Invariant estimates and exact references (SPEC §7),
// the 3D sibling of curve/normals.hpp, with the length scale l of the unit-free defaults
// (surface/length_scale.hpp): R = k_R h^(1/3) l^(2/3), by default with k_R chosen in [1, 1.5] as
// the object's thickness allows (ii_ball_radius()).
#pragma once

#include "digilap/surface/shapes.hpp"
#include "digilap/surface/surfels.hpp"

#include <Eigen/Core>

#include <vector>

namespace digilap::surface {

struct SurfelNormals {
  Eigen::MatrixX3d normals;  ///< one unit normal per surfel
  double length_scale = 0;   ///< l (0: unknown)
  double radius = 0;         ///< the II ball radius R used (0 for exact normals)
  /// l_c of each connected surface (surfel order: SurfelSet::surface_offset), from which each
  /// surface's heat time follows; empty when l was given.
  std::vector<double> surface_length_scales;
};

struct SurfaceNormalOptions {
  /// R = k_R h^(1/3) l^(2/3); 0 (the default) chooses k_R in [1, 1.5] from l (ii_ball_radius()).
  double k_R = 0.0;
  /// l; 0 measures it (surface/length_scale.hpp: per surface, the quantile of 1 / |H| over its
  /// surfels within [4 voxels, its equal-volume radius], l their weighted median). Give 1 for
  /// R = k_R h^(1/3).
  double length_scale = 0.0;
  /// Which quantile of the radii of curvature a measured l is.
  double length_quantile = 0.02;
  /// Remove the digital ball's own anisotropy from the covariance (ii_normals); false gives
  /// SPEC §7's plain estimator, whose area swings by +-3% with rho (docs/accuracy.md).
  bool remove_ball_anisotropy = true;
};

/// The II ball radius at step h for the length scale l. A given k_R > 0: R = k_R h^(1/3) l^(2/3).
/// k_R = 0: the widest ball with k_R in [1, 1.5] that stays within l / 2,
///
///   R = max(h^(1/3) l^(2/3), min(1.5 h^(1/3) l^(2/3), l / 2)),
///
/// i.e. k_R = clamp((l / h)^(1/3) / 2, 1, 1.5). A wider ball averages the digitization's noise
/// out of the normals (and so out of the measures, whose sum is the area), but must not reach
/// across a thin part: below l / h = 8 voxels (thin tubes, the labels of an atlas) this is k_R = 1,
/// from 27 voxels on k_R = 1.5 (docs/accuracy.md, "The digital ball's anisotropy, removed; a
/// radius from l / h").
/// Throws digilap::Error for k_R < 0 or not finite, or h or l not > 0 and finite.
double ii_ball_radius(double k_R, double h, double l);

/// II normals: the eigenvector of the smallest eigenvalue of the covariance of the set's voxel
/// centres in the closed ball of radius R around each surfel centre (less 19/64 of the digital
/// ball's own anisotropy where its two least eigenvalues are well apart, unless
/// options.remove_ball_anisotropy is false), oriented away from the
/// centroid of those voxels (SPEC §7: the sign of <n, n_e> can flip where n_e is nearly
/// tangent). Cost O((R/h)^2) per surfel from the runs of the ball's rows, parallel, identical
/// for any thread count. Throws digilap::Error for k_R < 0, a given l not > 0, either not finite, or a
/// ball wider than the whole set.
SurfelNormals ii_normals(const VoxelSet& set, const SurfelSet& surfels, const SurfaceNormalOptions& options = {});
namespace detail {
/// The II normals' estimate with a given ball radius rho (voxels) and no check: what ii_normals
/// computes once R is known (the distributed pipeline, whose slab is not the whole set, checks
/// R against the whole set itself).
Eigen::MatrixX3d ii_normals_at(const VoxelSet& set, const SurfelSet& surfels, double rho, bool remove_ball_anisotropy = true);
}  // namespace detail

/// The exact outward normals at the surfel centres' closest points (separates the estimator's
/// error from the operator's). Their length scale is `length_scale` if > 0, else the one
/// length_scale() measures on the surface's digitization at the surfels' h: the same l (and per
/// surface l_c) as the II normals get, so that both lead to the same t (as curve::exact_normals).
/// Throws digilap::Error for a negative or non-finite length_scale.
SurfelNormals exact_normals(const Surface& surface, const SurfelSet& surfels, double length_scale = 0.0);
/// The same with the voxel set the surfels come from (no second digitization) and the II
/// normals' options: l is options.length_scale, or measured at options.length_quantile.
SurfelNormals exact_normals(const Surface& surface, const VoxelSet& set, const SurfelSet& surfels,
                            const SurfaceNormalOptions& options);

}  // namespace digilap::surface
