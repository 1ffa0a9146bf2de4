// Internal: exact integer moments of the voxel centres of a set inside a ball, in O(rho^2) per
// ball through the runs of its rows: shared by the II normals and the II mean curvature of the
// surface length scale (the 3D sibling of lib/disk_moments.hpp).
#pragma once

#include "digilap/surface/digitization.hpp"
#include "digilap/surface/surfels.hpp"

#include <Eigen/Core>

#include <cstdint>

namespace digilap::surface::detail {

/// Moments of the voxel centres in a ball, relative to a voxel near its centre.
struct Moments {
  std::int64_t n = 0, s[3] = {0, 0, 0}, ss[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
};

/// The ball of radius rho (voxels) around (X, Y, Z) / 2 (doubled coordinates: surfel centres are
/// integers there).
Moments ball_moments(const VoxelSet& set, std::int64_t X, std::int64_t Y, std::int64_t Z, double rho);

/// Doubled coordinates of a surfel's centre.
Eigen::Matrix<std::int64_t, 3, 1> doubled_centre(const Surfel& f);

}  // namespace digilap::surface::detail
