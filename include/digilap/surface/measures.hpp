// digilap — areas of the surfels (SPEC §7), the 3D sibling of curve/measures.hpp.
#pragma once

#include "digilap/surface/normals.hpp"

#include <Eigen/Core>

namespace digilap::surface {

struct SurfelMeasures {
  Eigen::VectorXd mu;        ///< mu = h^2 max(0, <n, n_e>) of each surfel
  std::size_t clamped = 0;   ///< surfels with <n, n_e> <= 0 (mu = 0)
  double length_scale = 0;   ///< l and R of the normals: the operator's default t follows l
  double normal_radius = 0;
  /// l_c of each connected surface (SurfelNormals::surface_length_scales; empty when l was given).
  std::vector<double> surface_length_scales;
  /// The unit normals the areas came from (SurfaceKernel::Intrinsic needs them; measures built
  /// by hand may leave them empty).
  Eigen::MatrixX3d normals;
  double total_area() const { return mu.sum(); }
};

/// The surfels' areas from their normals: sum mu converges to the surface's area. Throws
/// digilap::Error when the normals do not match the surfels.
SurfelMeasures measures(const SurfelSet& surfels, const SurfelNormals& normals);

}  // namespace digilap::surface
