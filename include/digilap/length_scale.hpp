// digilap — the length scale l of a digital shape, measured on its pixels, from which the
// default heat time and II radius follow without hidden units (SPEC §2, §4; docs/accuracy.md):
//
//   t = c_t h^(2/3) l^(4/3),   R = k_R h^(1/3) l^(2/3)
//
// so that scaling a shape and h by s scales t by s^2, R by s and L by 1 / s^2: the same pixels
// give the same answer whatever the units, the canvas or the size of the shape.
//
// l is a robust small radius of curvature. On each contour, l_c is the `quantile` (2%) of the
// radii of curvature 1 / |kappa| that the Integral Invariant curvature estimator gives at its
// linels (kappa = 3 pi / (2 R) - 3 A / R^3, A the area of the set in the disk of radius R around
// the linel), bounded above by the contour's equal-area radius (a circle's radius of curvature
// is its radius, a straight part's is infinite) and below by 4 pixels (corners, pixel noise and
// one-pixel-wide parts cannot drive it to 0), or by that radius for an object smaller than that. l is the median of the l_c weighted by the
// contours' linels: a tiny contour does not dictate it for a large one. It is what the error of
// the operator scales with: the bias of the heat kernel on a function with curvature-driven
// second derivatives is O(t / rho^2), the estimator's error O((h / rho)^(2/3)). R itself is
// chosen from l, so l is a fixed point: three rounds starting from the size bound. Computed in
// pixel units from the pixels alone (h only multiplies the result), on at most 20,000 linels.
#pragma once

#include "digilap/contour.hpp"
#include "digilap/digitization.hpp"

#include <vector>

namespace digilap {

struct LengthScaleOptions {
  /// Constant of the disk radius R = k_R h^(1/3) l^(2/3) of the curvature estimator (the II
  /// normals' default).
  double k_R = 2.0;
  /// Which quantile of the radii of curvature (0.02: the smallest 2% of the boundary; the
  /// study in docs/accuracy.md compares 0.01 to 0.1).
  double quantile = 0.02;
};

struct LengthScale {
  double length = 0;        ///< l, in the units of h
  double size_bound = 0;    ///< equal-area radius of the largest contour (l's upper bound)
  double floor = 0;         ///< 4 h, or less for a set whose largest contour is smaller (l's lower bound)
  std::size_t samples = 0;  ///< linels whose curvature was estimated
  /// l_c of each contour: its own quantile within [4 h, its equal-area radius] (0 for a contour
  /// too short to be sampled). l is their median weighted by the contours' linels.
  std::vector<double> per_contour;
};

/// The length scale of a digital set's contours. An empty set of contours gives l = 4 h.
/// Throws digilap::Error for k_R not > 0 and finite, or a quantile outside (0, 1).
LengthScale length_scale(const DigitalSet& set, const ContourSet& contours, const LengthScaleOptions& options = {});

}  // namespace digilap
