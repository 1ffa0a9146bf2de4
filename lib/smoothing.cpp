#include "digilap/smoothing.hpp"

#include "digilap/error.hpp"
#include "digilap/heat_flow.hpp"

#include <cmath>
#include <sstream>
#include <string>

namespace digilap {

namespace {
void check_tau(double tau, int steps) {
  if (!(tau > 0) || !std::isfinite(tau) || steps < 1) {
    std::ostringstream msg;
    msg << "smoothing: tau must be > 0 and finite and steps >= 1, got tau = " << tau << ", steps = " << steps;
    throw Error(msg.str());
  }
}

Eigen::MatrixXd advance_columns(const HeatFlow& flow, const Eigen::MatrixXd& f, int steps) {
  Eigen::MatrixXd out(f.rows(), f.cols());
  for (Eigen::Index k = 0; k < f.cols(); ++k) out.col(k) = flow.advance(f.col(k), steps);
  return out;
}

Eigen::Vector2d centroid(const Eigen::MatrixX2d& p, Eigen::Index a, Eigen::Index b) {
  return p.middleRows(a, b - a).colwise().mean().transpose();
}
}  // namespace

Eigen::MatrixXd smooth(const SparseMatrix& A, const Eigen::VectorXd& mass, const Eigen::MatrixXd& f, double tau, int steps) {
  check_tau(tau, steps);
  if (f.rows() != mass.size()) throw Error("smooth: the functions have " + std::to_string(f.rows()) + " rows, the operator " + std::to_string(mass.size()));
  return advance_columns(HeatFlow(A, mass, tau / steps, TimeScheme::ImplicitEuler), f, steps);
}

Eigen::MatrixXd smooth(const HeatOperator& op, const Eigen::MatrixXd& f, double tau, int steps) {
  check_tau(tau, steps);
  if (f.rows() != op.rows()) throw Error("smooth: the functions have " + std::to_string(f.rows()) + " rows, the operator " + std::to_string(op.rows()));
  return advance_columns(HeatFlow(op, tau / steps, TimeScheme::ImplicitEuler), f, steps);
}

Eigen::VectorXd smooth_function(const HeatOperator& op, const Eigen::VectorXd& f, double tau, int steps) {
  check_tau(tau, steps);
  if (f.size() != op.rows()) throw Error("smooth_function: the function has the wrong size");
  return HeatFlow(op, tau / steps, TimeScheme::ImplicitEuler).advance(f, steps);
}

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
  if (b - a < 3) throw Error("roundness: a contour needs at least 3 points");
  const Eigen::Vector2d c = centroid(p, a, b);
  Eigen::VectorXd r(b - a);
  for (Eigen::Index i = a; i < b; ++i) r[i - a] = (p.row(i).transpose() - c).norm();
  const double mean = r.mean();
  return std::sqrt((r.array() - mean).square().mean()) / mean;
}

Eigen::MatrixX2d smooth_positions(const ContourOperator& op, const ContourSmoothingOptions& o) {
  check_tau(o.tau, o.steps);
  const HeatFlow flow(op, o.tau / o.steps, TimeScheme::ImplicitEuler);
  Eigen::MatrixX2d p(op.rows(), 2);
  for (int k = 0; k < 2; ++k) p.col(k) = flow.advance(op.positions.col(k), o.steps);
  if (o.preserve_area) {
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

}  // namespace digilap
