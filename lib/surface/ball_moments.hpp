// Internal: exact integer moments of the voxel centres of a set inside a ball, in O(rho^2) per
// ball through the runs of its rows: shared by the II normals and the II mean curvature of the
// surface length scale (the 3D sibling of lib/disk_moments.hpp).
#pragma once

#include "digilap/surface/digitization.hpp"
#include "digilap/surface/surfels.hpp"

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <vector>

namespace digilap::surface::detail {

/// Moments of the voxel centres in a ball, relative to a voxel near its centre.
struct Moments {
  std::int64_t n = 0, s[3] = {0, 0, 0}, ss[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
};

/// The rows of the ball of radius rho (voxels) around a surfel's centre, computed once for all
/// surfels: each row's extent (an integer square root) was 45% of the II normals' time when
/// every ball recomputed it. A surfel's centre is a voxel centre moved by half a voxel along
/// the surfel's axis, so the ball's rows relative to that voxel depend only on the axis: three
/// tables of about pi rho^2 rows, 16 bytes each (ii_normals refuses a ball wider than twice the set).
class BallRows {
public:
  explicit BallRows(double rho);
  double radius() const { return rho_; }
  /// The moments of the set's voxel centres in the ball around f's centre (doubled_centre(f) / 2),
  /// relative to the voxel floor(doubled_centre(f) / 2).
  Moments moments(const VoxelSet& set, const Surfel& f) const;
  /// Their count alone (the II mean curvature's volume): moments(set, f).n.
  std::int64_t count(const VoxelSet& set, const Surfel& f) const;
  /// The deviatoric part D = C - tr(C) / 3 I of the covariance C of all the voxel centres in the
  /// ball around a surfel of this axis: the direction the digital ball has (0 for a round ball).
  const Eigen::Matrix3d& anisotropy(int axis) const { return anisotropy_[static_cast<std::size_t>(axis)]; }

private:
  template <typename RowFunction>
  void for_rows(const Surfel& f, const RowFunction& row) const;
  struct Row {
    std::int32_t dj, dk;  // the row (j0 + dj, k0 + dk)
    std::int32_t lo, hi;  // its voxels i0 + lo ... i0 + hi
  };
  double rho_;
  std::array<std::vector<Row>, 3> rows_;  // by the surfel's axis
  std::array<Eigen::Matrix3d, 3> anisotropy_;
};

/// Doubled coordinates of a surfel's centre.
Eigen::Matrix<std::int64_t, 3, 1> doubled_centre(const Surfel& f);

}  // namespace digilap::surface::detail
