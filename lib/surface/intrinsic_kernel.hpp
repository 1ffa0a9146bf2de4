// Internal: the per-surfel factors of SurfaceKernel::Intrinsic (core/heat_kernel.hpp), shared by
// the assembled operator, the matrix-free products and the distributed rows.
//
// The Gaussian of the geodesic distance d has its own O(t) bias on a curved surface. The heat
// kernel is p_t = (4 pi t)^(-1) exp(-d^2 / 4t) (1 + K_m d^2 / 12 + t (K_i + K_j) / 6 + ...) (the
// Van Vleck-Morette determinant, K_m the Gaussian curvature at the pair's midpoint, and the first
// heat invariant K / 3), and p_t's operator is (e^(t Delta) - 1) / t exactly; so the Gaussian
// alone gives that minus t div(K grad f) to first order (K Delta f and grad K . grad f both): on
// the unit sphere every eigenvalue low by a factor 1 - t (a quadrature of its symbol: -0.995 t to
// -1.002 t for l = 1 ... 4 at t = 1e-3; docs/accuracy.md). Each weight w_ij is multiplied by
// (1 + g_i)(1 + g_j), g = t K / 2, to first order 1 + t (K_i + K_j) / 2, which adds back
// t div(K grad f), both parts (the symmetric factor's gradient is half its diagonal's), written as a
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
