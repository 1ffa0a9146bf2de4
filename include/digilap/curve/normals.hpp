// digilap — normals of the linels: Integral Invariant estimates and exact references (SPEC §2).
#pragma once

#include "digilap/curve/contour.hpp"
#include "digilap/curve/digitization.hpp"
#include "digilap/curve/shapes.hpp"

#include <Eigen/Core>

#include <vector>

namespace digilap {
inline namespace curve {

/// One unit normal per linel: normals[c].row(i) belongs to linel l_i of contour c; with the
/// length scale l they were estimated at (length_scale.hpp), carried on to the measures and the
/// operator's default heat time.
struct LinelNormals : std::vector<Eigen::MatrixX2d> {
  using std::vector<Eigen::MatrixX2d>::vector;
  double length_scale = 0;  ///< l (0: unknown, then the operator needs an explicit t or l)
  double radius = 0;        ///< the II disk radius R used (0 for exact normals)
  /// l_c of each contour when l was measured (LengthScale::per_contour, l for a contour too
  /// short to be sampled); empty when l was given. The geodesic operator's default heat time is
  /// per contour: contours that do not interact need not share one.
  std::vector<double> contour_length_scales;
};

struct IINormalOptions {
  /// Radius R = k_R h^(1/3) l^(2/3) of the integration disk, with l the shape's length scale
  /// (length_scale.hpp): unit-free, R stays a fixed fraction of the shape's smallest radius of
  /// curvature at a given resolution h / l. k_R = 2 from the study in docs/accuracy.md.
  double k_R = 2.0;
  /// l; 0 (the default) measures it on the set with length_scale(). Give 1 to get the former
  /// R = k_R h^(1/3) in the set's units.
  double length_scale = 0.0;
  /// Which quantile of the radii of curvature a measured l is (LengthScaleOptions::quantile).
  double length_quantile = 0.02;
};

/// Integral Invariant covariance normals [LCL14]: for each linel, the eigenvector of the
/// smallest eigenvalue of the covariance of the set's pixel centres lying in the closed disk of
/// radius R around the linel's midpoint, oriented along the trivial normal n_e.
/// The result carries l and R. Cost O(R/h) per linel (row moments of the runs, not a pixel loop), parallel with OpenMP,
/// identical for any thread count. Throws digilap::Error for k_R <= 0 or not finite, or for a
/// disk larger than the whole set (R greater than the set's diameter).
LinelNormals ii_normals(const DigitalSet& set, const ContourSet& contours, const IINormalOptions& options = {});

/// Exact normals: the outward normal of the continuous curve at the closest point of each
/// linel's midpoint (separates the estimator's error from the operator's). Their length scale
/// is `length_scale` if > 0, else the one length_scale() measures on the shape's digitization
/// at the contours' h: the same l as the II normals get, so that both lead to the same t.
LinelNormals exact_normals(const Shape& shape, const ContourSet& contours, double length_scale = 0.0);

}  // namespace curve
}  // namespace digilap
