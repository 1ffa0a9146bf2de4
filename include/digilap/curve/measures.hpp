// digilap — lengths of linels and vertices, arclength along contours, distances (SPEC §3).
#pragma once

#include "digilap/curve/contour.hpp"
#include "digilap/curve/normals.hpp"

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace digilap {
inline namespace curve {

/// Measures of one contour, all of size N (its number of linels = of vertices).
struct ContourMeasures {
  Eigen::VectorXd linel_mu;   // mu(l_i) = h <n(l_i), n_e(l_i)>, clamped at 0
  Eigen::VectorXd vertex_mu;  // mu(v_i) = (mu(l_{i-1}) + mu(l_i)) / 2
  Eigen::VectorXd S;          // S_0 = 0, S_{i+1} = S_i + mu(l_i): arclength of v_i
  double length = 0.0;        // P = S_N = sum of mu(l_i)

  /// Geodesic distance along the contour between v_i and v_j: min(|S_j - S_i|, P - |S_j - S_i|).
  double geodesic_distance(std::size_t i, std::size_t j) const;
};

// The deprecated field's copies and moves are the struct's own: not a use by the caller.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
struct Measures {
  std::vector<ContourMeasures> contours;
  /// Linels where <n, n_e> <= 0 (normal flipped or orthogonal to the linel): mu clamped to 0.
  /// Should be 0; a positive count says k_R is too large for the shape's curvature (SPEC §2).
  std::size_t clamped = 0;
  [[deprecated("renamed clamped, as in surface::SurfelMeasures")]] std::size_t clamped_linels = 0;
  /// The length scale l and II radius R of the normals (length_scale.hpp): the operator's
  /// default heat time is c_t h^(2/3) l^(4/3).
  double length_scale = 0;
  double normal_radius = 0;
  /// l_c of each contour (LinelNormals::contour_length_scales; empty when l was given).
  std::vector<double> contour_length_scales;
  /// Total estimated length of all contours.
  double total_length() const;
};
#pragma GCC diagnostic pop

/// Linel and vertex measures from the linel normals (II estimates or exact ones).
/// Throws digilap::Error when the normals do not match the contours in size.
Measures measures(const ContourSet& contours, const LinelNormals& normals);

}  // namespace curve
}  // namespace digilap
