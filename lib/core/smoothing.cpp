#include "digilap/core/smoothing.hpp"

#include "digilap/core/error.hpp"
#include "digilap/core/heat_flow.hpp"

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

double roundness(const Eigen::Ref<const Eigen::MatrixXd>& p, const Eigen::Ref<const Eigen::VectorXd>& w) {
  if (p.rows() < 3 || w.size() != p.rows())
    throw Error("roundness: needs at least 3 points and one weight each, got " + std::to_string(p.rows()) + " points and " +
                std::to_string(w.size()) + " weights");
  if (!(w.minCoeff() >= 0) || !std::isfinite(w.sum()) || !(w.sum() > 0))
    throw Error("roundness: the weights must be >= 0 and finite with a positive sum");
  const double total = w.sum();
  const Eigen::RowVectorXd c = (w.transpose() * p) / total;
  const Eigen::VectorXd r = (p.rowwise() - c).rowwise().norm();
  const double mean = w.dot(r) / total;
  return std::sqrt(w.dot((r.array() - mean).square().matrix()) / total) / mean;
}

}  // namespace digilap
