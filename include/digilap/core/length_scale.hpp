// digilap — the length scale l of a digital shape (core): its options and its result, the same
// for curves (curve/length_scale.hpp, on the pixels) and surfaces (surface/length_scale.hpp, on
// the voxels). The default heat time and II radius follow from it without hidden units:
//
//   t = c_t h^(2/3) l^(4/3),   R = k_R h^(1/3) l^(2/3).
#pragma once

#include <cstddef>
#include <vector>

namespace digilap {

struct LengthScaleOptions {
  /// Constant of the disk radius R = k_R h^(1/3) l^(2/3) of the curvature estimator (the II
  /// normals' default).
  double k_R = 2.0;
  /// Which quantile of the radii of curvature (0.02: the smallest 2% of the boundary; the
  /// study in docs/accuracy.md compares 0.01 to 0.1).
  double quantile = 0.02;
};

struct LengthScale {
  double length = 0;        ///< l, in the units of h
  double size_bound = 0;    ///< l's upper bound: the largest contour's equal-area radius (surface: equal-volume)
  double floor = 0;         ///< 4 h, or less for a set whose largest contour (surface) is smaller (l's lower bound)
  std::size_t samples = 0;  ///< linels (surfels) whose curvature was estimated
  /// l_c of each contour (surface): its own quantile within [4 h, its equal-area radius] (0 for
  /// one too small to be sampled). l is their median weighted by their linels (surfels).
  std::vector<double> per_contour;
};

}  // namespace digilap
