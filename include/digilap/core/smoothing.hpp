// digilap — Laplacian smoothing of functions on an operator's rows, any dimension (core): heat
// diffusion for a time tau with implicit Euler. curve/smoothing.hpp and surface/smoothing.hpp
// smooth the contours and surfaces themselves (their positions) with it.
#pragma once

#include "digilap/core/operator.hpp"

#include <Eigen/Core>

namespace digilap {

/// Columns of f (functions on the rows of (A, M), any number: values, positions in 2D or 3D)
/// diffused for time tau by the heat flow of (A, M), implicit Euler in `steps` equal steps: the
/// dimension-free core of the smoothing functions. Throws digilap::Error for tau not > 0 and
/// finite, steps < 1, a size mismatch, or a mass that is not > 0 (zero-mass rows need the
/// operator: smooth(op, f, tau, steps)).
Eigen::MatrixXd smooth(const SparseMatrix& A, const Eigen::VectorXd& mass, const Eigen::MatrixXd& f, double tau, int steps = 1);
/// The same from an operator of any dimension: zero-mass rows follow their row of L.
Eigen::MatrixXd smooth(const HeatOperator& op, const Eigen::MatrixXd& f, double tau, int steps = 1);

/// A function on an operator's rows (contours or surfaces) smoothed by diffusion for time tau;
/// zero-mass rows follow their row of L (core/heat_flow.hpp). Throws digilap::Error for tau not > 0
/// and finite, steps < 1, a size mismatch, or as HeatFlow(op, dt).
Eigen::VectorXd smooth_function(const HeatOperator& op, const Eigen::VectorXd& f, double tau, int steps = 1);

/// Roundness of weighted points in any dimension (rows of `positions`: a contour's elements or a
/// surface's surfels, weighted by their masses): the weighted standard deviation of the distance
/// to the weighted centroid divided by its weighted mean; 0 for points on a circle or a sphere.
/// Throws digilap::Error for fewer than 3 points, a weight per point missing, or weights not
/// >= 0 and finite with a positive sum.
double roundness(const Eigen::Ref<const Eigen::MatrixXd>& positions, const Eigen::Ref<const Eigen::VectorXd>& weights);

}  // namespace digilap
