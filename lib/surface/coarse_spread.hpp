// Internal: values known on aggregates of surfels (a coarse problem's eigenvectors) spread back
// onto the surfels, smoothly. The matrix-free spectrum starts LOBPCG from them
// (matrix_free.cpp, coarse_start).
#pragma once

#include <Eigen/Core>

#include <vector>

namespace digilap::surface::detail {

/// `values` (a row per aggregate, at `centres`, mean normals `centre_normals`) on `points`
/// (normals `point_normals`): each point takes the average of the aggregates within 1.5 `cell`
/// of it, weighted by a Gaussian of half a cell; with `by_side`, only those on its side of the
/// surface (mean normal within 60 degrees of its own, so that the two sides of a thin wall stay
/// apart). A point with none takes its own aggregate's value (`own[point]`). Constants are kept
/// exactly; each row is computed on its own, the same bits on any number of threads.
///
/// Why not each point its own aggregate's value: that puts steps at the aggregates' borders,
/// which the heat operator sees at the top of its spectrum (a sphere at h = 0.025: the start's
/// residual 2.4e-2 c, c the spectrum's bound, against 6.4e-3 c spread so; docs/benchmarks.md).
Eigen::MatrixXd spread_smoothly(const Eigen::MatrixXd& values, const Eigen::MatrixX3d& centres, const Eigen::MatrixX3d& centre_normals,
                                const Eigen::MatrixX3d& points, const Eigen::MatrixX3d& point_normals, const std::vector<int>& own,
                                double cell, bool by_side);

}  // namespace digilap::surface::detail
