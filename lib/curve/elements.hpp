// Internal: the elements of the contours in row order, and the geodesic window of a row.
// Shared by the explicit assembly and the matrix-free operator, so that both see the same
// elements and the same neighbours, bit for bit.
#pragma once

#include "digilap/curve/heat_laplacian.hpp"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <vector>

namespace digilap::detail {

struct Elements {
  Eigen::MatrixX2d positions;
  Eigen::VectorXd mu, s;
  std::vector<Eigen::Index> offset{0};
  std::vector<double> length;
};

/// Elements of every contour (pointels or linel midpoints), with measures and arclengths.
/// Throws digilap::Error when the measures do not match the contours.
Elements gather_elements(const ContourSet& contours, const Measures& measures, Placement placement);

/// A cyclic window of a row along its contour: the elements i - back .. i + fwd (mod n).
struct GeodesicWindow {
  Eigen::Index back = 0, fwd = 0;
};

/// Symmetric distance along a contour (SPEC §3): the same bits for (i, j) and (j, i).
inline double cyclic_distance(double si, double sj, double P) {
  const double d = std::abs(sj - si);
  return std::min(d, P - d);
}

/// The elements within distance `cut` of element i of a contour of n elements with sorted
/// arclengths s and length P: binary search on the forward and backward offsets, settled with
/// cyclic_distance itself. When cut >= P / 2, every other element once.
GeodesicWindow geodesic_window(const double* s, Eigen::Index n, Eigen::Index i, double P, double cut);

}  // namespace digilap::detail
