#include "digilap/curve/smoothing.hpp"

#include "digilap/core/error.hpp"
#include "digilap/core/heat_flow.hpp"

#include <cmath>
#include <sstream>
#include <string>

namespace digilap {
inline namespace curve {

namespace {
Eigen::Vector2d centroid(const Eigen::MatrixX2d& p, Eigen::Index a, Eigen::Index b) {
  return p.middleRows(a, b - a).colwise().mean().transpose();
}
}  // namespace

Eigen::VectorXd enclosed_areas(const ContourOperator& op, const Eigen::MatrixX2d& p) {
  Eigen::VectorXd areas(static_cast<Eigen::Index>(op.row_offset.size()) - 1);
  for (Eigen::Index c = 0; c + 1 < static_cast<Eigen::Index>(op.row_offset.size()); ++c) {
    const Eigen::Index a = op.row_offset[c], b = op.row_offset[c + 1];
    double twice = 0;
    for (Eigen::Index r = a; r < b; ++r) {
      const Eigen::Index s = (r + 1 < b) ? r + 1 : a;
      twice += p(r, 0) * p(s, 1) - p(s, 0) * p(r, 1);
    }
    areas[c] = 0.5 * twice;
  }
  return areas;
}

double roundness(const Eigen::MatrixX2d& p, Eigen::Index a, Eigen::Index b) {
  if (a < 0 || b > p.rows() || b - a < 3) throw Error("roundness: a contour needs at least 3 points");
  return digilap::roundness(p.middleRows(a, b - a), Eigen::VectorXd::Ones(b - a));
}

Eigen::MatrixX2d smooth_positions(const ContourOperator& op, const ContourSmoothingOptions& o) {
  // x and y as two functions, through the core's smoothing (the same flow, step for step).
  Eigen::MatrixX2d p = smooth(op, Eigen::MatrixXd(op.positions), o.tau, o.steps);
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
  const bool preserve_size = o.preserve_size && o.preserve_area;  // the earlier name still switches it off
#pragma GCC diagnostic pop
  if (preserve_size) {
    const Eigen::VectorXd before = enclosed_areas(op, op.positions), after = enclosed_areas(op, p);
    for (Eigen::Index c = 0; c < before.size(); ++c) {
      if (!(after[c] * before[c] > 0)) continue;  // collapsed or flipped: nothing sensible to rescale
      const Eigen::Index a = op.row_offset[c], b = op.row_offset[c + 1];
      const Eigen::RowVector2d g = centroid(p, a, b).transpose();
      const double s = std::sqrt(before[c] / after[c]);
      p.middleRows(a, b - a) = ((p.middleRows(a, b - a).rowwise() - g) * s).rowwise() + g;
    }
  }
  return p;
}

}  // namespace curve
}  // namespace digilap
