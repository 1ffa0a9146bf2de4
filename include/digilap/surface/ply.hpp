// digilap — surfels as a PLY quad mesh (binary little-endian), with per-surfel scalar fields
// (eigenvectors, heat, mu) as face properties, for MeshLab and ParaView.
#pragma once

#include "digilap/surface/surfels.hpp"

#include <Eigen/Core>

#include <string>
#include <utility>
#include <vector>

namespace digilap::surface {

struct PlyMeshSize {
  std::size_t vertices = 0, faces = 0;
};

/// Writes one quad per surfel (corners shared between surfels, counter-clockwise seen from
/// outside) and, per face, a float property for each named field (one value per surfel).
/// Returns the mesh's size. Throws digilap::Error for a field of the wrong size, a name that is
/// not a PLY word, or a file that cannot be written.
PlyMeshSize save_ply(const SurfelSet& surfels, const std::vector<std::pair<std::string, Eigen::VectorXd>>& fields,
                     const std::string& path);

}  // namespace digilap::surface
