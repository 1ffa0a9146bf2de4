// digilap — the length scale l of a digital surface, measured on its voxels, from which the
// default heat time and II radius follow without hidden units: the 3D sibling of
// curve/length_scale.hpp, with the same options and result,
//
//   t = c_t h^(2/3) l^(4/3),   R = k_R h^(1/3) l^(2/3).
//
// On each connected surface c (SurfelSet::surface_offset), l_c is the `quantile` (2%) of the
// radii of curvature 1 / |H| that the Integral Invariant mean curvature gives at its surfels
// (H = 8 / (3 rho) - 4 V / (pi rho^4), V the volume of the set in the ball of radius rho
// around the surfel), bounded above by the equal-volume radius of what the surface encloses and
// below by 4 voxels (or that radius for a smaller object). l is the median of the l_c weighted by
// the surfaces' surfels, so that specks do not dictate it for a large object; the ball's radius
// follows from l (rho = k_R l^(2/3) voxels, at most the largest surface's radius), hence three
// rounds from the size bound. Computed in voxel units (h only multiplies the result), on at
// most 20,000 surfels: all of them below that, else a sample chosen by position in the set's
// bounding box so that it maps onto itself under the lattice's symmetries (the axes permuted or
// flipped give the same l, whatever the storage order).
#pragma once

#include "digilap/core/length_scale.hpp"
#include "digilap/surface/digitization.hpp"
#include "digilap/surface/surfels.hpp"

namespace digilap::surface {

/// The length scale of a voxel set's surfaces (LengthScale::per_contour holds l_c of each
/// surface, 0 for one too small to be sampled). An empty set gives l = 4 h. Throws
/// digilap::Error for k_R not > 0 and finite, or a quantile outside (0, 1).
LengthScale length_scale(const VoxelSet& set, const SurfelSet& surfels, const LengthScaleOptions& options = {});

}  // namespace digilap::surface
