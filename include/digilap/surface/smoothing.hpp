// digilap — fairing of digital surfaces: the surfel centres diffused by the surface operator,
// the 3D sibling of curve/smoothing.hpp (same stopping parameter tau, same heat flow on (A, M)).
#pragma once

#include "digilap/core/smoothing.hpp"
#include "digilap/surface/heat_laplacian.hpp"

#include <Eigen/Core>

namespace digilap::surface {

struct SurfaceSmoothingOptions {
  double tau = 1e-2;  ///< diffusion time (the stopping parameter, see curve/smoothing.hpp)
  int steps = 4;      ///< implicit Euler steps
  /// Rescale each connected surface about its centroid after smoothing so that its
  /// area-weighted RMS distance to the centroid is what it was (diffusion shrinks surfaces: a
  /// sphere of radius r by exp(-2 tau / r^2)).
  bool preserve_size = true;
};

/// The surfel centres (x, y, z as functions) diffused for time tau by the operator's heat flow
/// (a linearized mean-curvature flow). Returns the new positions, row by row. The flow
/// factorizes M - dt A once (sparse LDL^T), whose fill-in grows quickly with 1 / h in 3D
/// (seconds at h = 0.07 on the unit sphere). Throws digilap::Error for tau not > 0 and finite,
/// steps < 1, or a mass that is not > 0.
Eigen::MatrixX3d smooth_positions(const SurfaceOperator& op, const SurfaceSmoothingOptions& options = {});

/// Roundness of a set of points weighted by their areas: the core's (core/smoothing.hpp).
using digilap::roundness;

}  // namespace digilap::surface
