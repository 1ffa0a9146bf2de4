// digilap — the boundary of a voxel set: its surfels (SPEC §7), the 3D sibling of curve/contour.hpp.
// A surfel is the unit square face between a voxel of the set and a 6-neighbour outside it;
// objects touching by an edge or a corner only are separated (the set is 6-connected).
#pragma once

#include "digilap/surface/digitization.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace digilap::surface {

struct Surfel {
  Eigen::Vector3i voxel;  ///< the voxel inside
  std::int8_t axis = 0;   ///< 0, 1, 2: the face is orthogonal to x, y or z
  std::int8_t sign = 1;   ///< +1 or -1: the outside neighbour is voxel + sign e_axis
};

struct SurfelSet {
  double h = 1.0;
  std::vector<Surfel> surfels;
  /// Surfels grouped by connected surface (connected_surfaces), as contours group linels:
  /// surface c is [surface_offset[c], surface_offset[c + 1]). extract_surfels and filter_surfels
  /// fill it; empty (a set made by hand) means one surface of all the surfels.
  std::vector<std::size_t> surface_offset;

  std::size_t size() const { return surfels.size(); }
  /// Number of surfaces (1 for a non-empty set made by hand, whose surface_offset is empty).
  std::size_t surfaces() const { return surface_offset.empty() ? (surfels.empty() ? 0 : 1) : surface_offset.size() - 1; }
  /// surface_offset, or {0, size()} for a set made by hand.
  std::vector<std::size_t> offsets() const;
  /// Centre of surfel s: voxel centre + (h / 2) n_e.
  Eigen::Vector3d centre(std::size_t s) const;
  /// Its trivial (outward, axis-aligned) normal n_e.
  Eigen::Vector3d trivial_normal(std::size_t s) const;
  /// Centres as an N x 3 matrix.
  Eigen::MatrixX3d centres() const;
};

/// Connected surfaces: surfels sharing an edge on the same sheet of the boundary. Across an
/// edge the next surfel is taken concave first, then flat, then convex, except that two voxels
/// meeting by an edge only are kept apart (the set is 6-connected, as the 2D contours keep
/// pixels meeting by a corner apart).
struct SurfelComponents {
  std::vector<int> of_surfel;       ///< component of each surfel, numbered by their first surfel
  std::vector<std::size_t> sizes;   ///< surfels per component
};
SurfelComponents connected_surfaces(const VoxelSet& set, const SurfelSet& surfels);

struct SurfelFilter {
  std::size_t min_surfels = 0;  ///< drop the surfaces with fewer surfels
  bool largest_only = false;    ///< keep only the surface with the most surfels
};
struct FilteredSurfels {
  SurfelSet surfels;        ///< the kept surfels, grouped by surface, in their original order within each
  std::size_t dropped = 0;  ///< surfaces dropped
};
FilteredSurfels filter_surfels(const VoxelSet& set, const SurfelSet& surfels, const SurfelFilter& filter);

/// The volume enclosed by the surfels [first, last) (closed surfaces), in the units of h^3: by
/// the divergence theorem, exact on the voxels (a whole set's surfels give its voxel count
/// times h^3; the surface of a cavity counts negative).
double enclosed_volume(const SurfelSet& surfels, std::size_t first, std::size_t last);
namespace detail {
/// Twice the enclosed volume in voxels, exactly (an integer).
std::int64_t twice_enclosed_voxels(const SurfelSet& surfels, std::size_t first, std::size_t last);
}  // namespace detail
/// The same for all the surfels.
inline double enclosed_volume(const SurfelSet& surfels) { return enclosed_volume(surfels, 0, surfels.size()); }

/// Every surfel of the set, grouped by connected surface (surface_offset; surfaces numbered by
/// their first surfel), row by row within each ((k, j) ascending, then i): the order depends
/// only on the set. Parallel over rows; each face found from the runs of the voxel's row and of
/// its four neighbouring rows (no voxel loop).
SurfelSet extract_surfels(const VoxelSet& set);
namespace detail {
/// The same surfels before grouping (surface_offset empty): row by row ((k, j) ascending), each
/// row's x-faces of its runs first, then its y- and z-faces. A surfel's place among those of its
/// row depends only on the voxels of that row and its four neighbouring rows, which is what lets
/// a slab of planes number its surfels as the whole set does (the distributed pipeline).
SurfelSet surfels_in_row_order(const VoxelSet& set);
}  // namespace detail

}  // namespace digilap::surface
