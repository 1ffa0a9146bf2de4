// Internal: the per-surfel factors of SurfaceKernel::Intrinsic (core/heat_kernel.hpp), shared by
// the assembled operator, the matrix-free products and the distributed rows.
//
// The Gaussian of the geodesic distance has its own O(t) bias on a curved surface, K t Delta f
// (K the Gaussian curvature) to first order, two terms of the mean of f over a geodesic circle
// of radius rho (Gray and Willmore: f + rho^2 Delta f / 4 + rho^4 (Delta^2 f + (2/3) K Delta f) / 64
// on a surface): the circles are short by K rho^2 / 6, which takes (4/3) K t off the second
// moment, and the rho^4 term gives (1/3) K t back. So the sphere's l(l+1) comes out low by a
// factor 1 - t (the kernel's symbol on the unit sphere, computed by quadrature: -0.995 t to
// -1.002 t for l = 1 ... 4 at t = 1e-3; docs/accuracy.md). Each weight w_ij is multiplied by
// (1 + g_i)(1 + g_j), g = t K / 2, to first order 1 + t (K_i + K_j) / 2, and written as a
// diagonal scaling: the weights' measures mu_i (1 + g_i), the mass matrix unchanged.
//
// K comes from the positions and normals alone, as kernel-weighted moments over each surfel's
// neighbours j (rho^2 = the tangent chord, w = exp(-rho^2 / 4t), sums weighted by w rho^2 mu_j):
//   H = sum w <x_j - x_i, n_j - n_i> / sum w rho^2        (the mean curvature, <d, e> ~ k_n rho^2)
//   (k1^2 + k2^2) / 2 = sum w |n_j - n_i|^2 / sum w rho^2
//   K = k1 k2 = 2 H^2 - (k1^2 + k2^2) / 2.
// Ratios of sums weighted by rho^2 so that the normals' noise (|n_j - n_i|^2 does not shrink with
// rho) is not divided by small rho^2. g is clamped to [-1/4, 1/4]: the correction is a first-order
// one, and a jagged real surface's K estimate may be large where t K is not small.
#pragma once

#include "digilap/core/error.hpp"
#include "digilap/surface/measures.hpp"
#include "surfel_grid.hpp"

#include <Eigen/Core>

#include <string>

namespace digilap::surface::detail {

/// Throws digilap::Error unless `measures` carry a finite normal for each of the n surfels.
inline void check_intrinsic_normals(const std::string& who, const SurfelMeasures& measures, Eigen::Index n) {
  if (measures.normals.rows() != n)
    throw Error(who + ": the intrinsic kernel needs the measures' normals, and they hold " + std::to_string(measures.normals.rows()) +
                " for " + std::to_string(n) + " surfels (surface::measures() keeps them; measures built by hand must set them, or "
                "choose the chord kernel, HeatLaplacianOptions::surface_kernel = SurfaceKernel::Chord)");
  if (!measures.normals.allFinite()) throw Error(who + ": the measures' normals are not all finite numbers");
}

/// The largest |g| = |t K / 2| applied.
constexpr double kMaxCurvatureCorrection = 0.25;

/// K of each point of `grid` (built with normals over a part's points, rows local to it), from
/// its neighbours within the kernel's cut whose normals are within 90 degrees; `mu` the part's
/// measures by local row. 0 where no neighbour counts. Each pair once, the grid's layers of cells
/// over the threads (TileLayers): the same bits on any number of threads.
Eigen::VectorXd estimated_gaussian_curvature(const Grid& grid, const Eigen::MatrixX3d& positions, const Eigen::MatrixX3d& normals,
                                             const Eigen::VectorXd& mu, const Kernel& kernel);

/// 1 + g_i, g_i = t K_i / 2 clamped to [-kMaxCurvatureCorrection, kMaxCurvatureCorrection], K
/// from estimated_gaussian_curvature with the same arguments, t the kernel's.
Eigen::VectorXd curvature_factors(const Grid& grid, const Eigen::MatrixX3d& positions, const Eigen::MatrixX3d& normals,
                                  const Eigen::VectorXd& mu, const Kernel& kernel);

}  // namespace digilap::surface::detail
