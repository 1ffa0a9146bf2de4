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

#include "digilap/core/length_scale.hpp"
#include "digilap/curve/contour.hpp"
#include "digilap/curve/digitization.hpp"

namespace digilap {
inline namespace curve {

/// The length scale of a digital set's contours. An empty set of contours gives l = 4 h.
/// Throws digilap::Error for k_R not > 0 and finite, or a quantile outside (0, 1).
LengthScale length_scale(const DigitalSet& set, const ContourSet& contours, const LengthScaleOptions& options = {});

}  // namespace curve
}  // namespace digilap
