// digilap — boundary contours of a digital set: pointels and linels (SPEC §1).
//
// Pointel (p, q) is the corner ((p + 1/2) h, (q + 1/2) h) of the pixel squares. A contour is a
// closed cycle of linels l_0 ... l_{N-1} through pointels v_0 ... v_{N-1}; linel l_i goes from v_i
// to v_{i+1} (indices mod N) in direction directions[i]. The set is always on the left:
// outer contours run counter-clockwise, holes clockwise. Where two pixels of the set touch by a
// corner only, the contour turns left, so that they are separated (the set is 4-connected);
// such a pointel appears twice among the vertices.
#pragma once

#include "digilap/curve/digitization.hpp"

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace digilap {
inline namespace curve {

/// Direction of a linel: +x, +y, -x, -y (a quarter turn to the left adds 1 modulo 4).
enum class Step : std::uint8_t { East = 0, North = 1, West = 2, South = 3 };

/// Unit vector of a step.
Eigen::Vector2i step_vector(Step s);
/// Trivial outward normal n_e of a linel: its direction turned a quarter to the right.
Eigen::Vector2d linel_normal(Step s);

struct Contour {
  std::vector<Eigen::Vector2i> pointels;  // v_i, as integer pointel coordinates (p, q)
  std::vector<Step> steps;                // direction of l_i, from v_i to v_{i+1}

  std::size_t size() const { return steps.size(); }
  /// Twice the signed area enclosed by the pointel polygon, in units of h^2 (exact integer):
  /// positive for an outer (counter-clockwise) contour, negative for a hole.
  std::int64_t twice_signed_area() const;
  bool is_hole() const { return twice_signed_area() < 0; }
};

struct ContourSet {
  double h = 1.0;
  std::vector<Contour> contours;

  std::size_t linel_count() const;
  /// Position of vertex v_i of contour c: ((p + 1/2) h, (q + 1/2) h).
  Eigen::Vector2d pointel_position(std::size_t c, std::size_t i) const;
  /// Midpoint of linel l_i of contour c.
  Eigen::Vector2d linel_midpoint(std::size_t c, std::size_t i) const;
};

/// Every contour of a digital set, outer ones and holes. Contours are ordered by their first
/// linel in (row, column) order of its start pointel, and each starts at that linel, so the
/// result depends only on the set. Cost O(L log L) for L linels; no bitmap is built.
ContourSet track_contours(const DigitalSet& set);

}  // namespace curve
}  // namespace digilap
