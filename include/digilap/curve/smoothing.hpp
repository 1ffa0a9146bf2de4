// digilap — Laplacian smoothing of functions on the contours and of the contours themselves.
//
// Smoothing is heat diffusion for a time tau (implicit Euler, `steps` equal steps), tau being
// the stopping parameter. A mode of wavelength lambda along the contour is damped by about
// exp(-(1 - exp(-omega^2 t)) tau / t), omega = 2 pi / lambda (SPEC §5): long waves by
// exp(-omega^2 tau) as in the continuous flow, but the heat-kernel operator's eigenvalues stop
// at 1/t, so the shortest features (noise) decay no faster than exp(-tau / t). Hence: take
// tau >= 5 t to remove noise (t = op.t), and tau << (lambda / 2 pi)^2 to keep features of
// wavelength lambda.
#pragma once

#include "digilap/core/smoothing.hpp"
#include "digilap/curve/heat_laplacian.hpp"

#include <Eigen/Core>

namespace digilap {
inline namespace curve {

// The deprecated field's copies and moves are the struct's own: not a use by the caller.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
struct ContourSmoothingOptions {
  double tau = 1e-2;  ///< diffusion time (the stopping parameter, see above)
  int steps = 4;      ///< implicit Euler steps
  /// Rescale each contour about its centroid after smoothing so that it encloses the area it
  /// enclosed before (diffusion shrinks curves: a circle of radius r by exp(-tau / r^2)).
  bool preserve_size = true;
  /// The earlier name: the rescaling runs when both are true.
  [[deprecated("renamed preserve_size, as in surface::SurfaceSmoothingOptions")]] bool preserve_area = true;
};
#pragma GCC diagnostic pop

/// Fairing of the contours: the element positions (x and y as functions) diffused by the
/// operator (a linearized curve-shortening flow). Returns the new positions, row by row.
Eigen::MatrixX2d smooth_positions(const ContourOperator& op, const ContourSmoothingOptions& options = {});

/// Signed area enclosed by each contour's polygon of element positions.
Eigen::VectorXd enclosed_areas(const ContourOperator& op, const Eigen::MatrixX2d& positions);

/// Roundness of one contour, its points weighted equally: the core's roundness(positions,
/// weights) (core/smoothing.hpp) of rows [first_row, end_row).
[[deprecated("use roundness(positions.middleRows(first, n), op.mass.segment(first, n)) from core/smoothing.hpp")]]
double roundness(const Eigen::MatrixX2d& positions, Eigen::Index first_row, Eigen::Index end_row);

}  // namespace curve
}  // namespace digilap
