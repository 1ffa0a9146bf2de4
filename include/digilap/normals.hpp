// digilap — normals of the linels: Integral Invariant estimates and exact references (SPEC §2).
#pragma once

#include "digilap/contour.hpp"
#include "digilap/digitization.hpp"
#include "digilap/shapes.hpp"

#include <Eigen/Core>

#include <vector>

namespace digilap {

/// One unit normal per linel: normals[c].row(i) belongs to linel l_i of contour c.
using LinelNormals = std::vector<Eigen::MatrixX2d>;

struct IINormalOptions {
  /// Radius R = k_R * h^(1/3) of the integration disk. k_R carries a length scale (units
  /// length^(2/3)): keep R small against the smallest radius of curvature. k_R = 1 suits the
  /// reference shapes (diameter 2 to 5) from h = 0.05 down (SPEC §2).
  double k_R = 1.0;
};

/// Integral Invariant covariance normals [LCL14]: for each linel, the eigenvector of the
/// smallest eigenvalue of the covariance of the set's pixel centres lying in the closed disk of
/// radius R around the linel's midpoint, oriented along the trivial normal n_e.
/// Cost O(R/h) per linel (row moments of the runs, not a pixel loop), parallel with OpenMP,
/// identical for any thread count. Throws digilap::Error for k_R <= 0 or not finite, or for a
/// disk larger than the whole set (R greater than the set's diameter).
LinelNormals ii_normals(const DigitalSet& set, const ContourSet& contours, const IINormalOptions& options = {});

/// Exact normals: the outward normal of the continuous curve at the closest point of each
/// linel's midpoint (separates the estimator's error from the operator's).
LinelNormals exact_normals(const Shape& shape, const ContourSet& contours);

}  // namespace digilap
