#include "digilap/surface/matrix_free_heat_flow.hpp"

#include "digilap/core/error.hpp"
#include "core/conjugate_gradients.hpp"

#include <cmath>
#include <sstream>

namespace digilap::surface {

namespace {
constexpr double kCgTolerance = 1e-12;  // relative residual of each step, as HeatFlow's
constexpr int kCgLimit = 10000;
}  // namespace

MatrixFreeHeatFlow::MatrixFreeHeatFlow(const MatrixFreeSurfaceOperator& op, double dt, TimeScheme scheme)
    : op_(op), dt_(dt), theta_(scheme == TimeScheme::ImplicitEuler ? 1.0 : 0.5) {
  require_positive("MatrixFreeHeatFlow: the time step dt", dt);
  const Eigen::VectorXd& mass = op.mass();
  lhs_diagonal_ = mass - (theta_ * dt_) * op.stiffness_diagonal();
  for (Eigen::Index i = 0; i < mass.size(); ++i) {
    if (mass[i] > 0) continue;
    if (!(op.laplacian_row_sums()[i] > 0))
      throw Error("MatrixFreeHeatFlow: surfel " + std::to_string(i) +
                  " has zero area and no neighbour of non-zero area within the cut: its surface has no area there");
    massless_.push_back(i);
    lhs_diagonal_[i] = 1.0;  // decoupled: its value is set from L after the others
  }
  inverse_diagonal_ = lhs_diagonal_.cwiseInverse();
}

Eigen::VectorXd MatrixFreeHeatFlow::stiffness(const Eigen::VectorXd& x) const {
  Eigen::MatrixXd y;
  op_.apply_stiffness(x, y);
  return y.col(0);
}

Eigen::VectorXd MatrixFreeHeatFlow::step(const Eigen::VectorXd& u) const {
  if (u.size() != op_.rows()) throw Error("MatrixFreeHeatFlow::step: the vector has the wrong size");
  const Eigen::VectorXd& mass = op_.mass();
  const Eigen::VectorXd& a_diagonal = op_.stiffness_diagonal();
  const double c = theta_ * dt_;
  // The zero-area rows and columns of A vanish: their entries of b are 0, their equation x_i = 0.
  const Eigen::VectorXd b = mass.cwiseProduct(u) + ((1.0 - theta_) * dt_) * stiffness(u);
  Eigen::VectorXd next = u;
  for (Eigen::Index i : massless_) next[i] = 0;
  auto apply = [&](const Eigen::VectorXd& x, Eigen::VectorXd& y) {
    y = stiffness(x);
    for (Eigen::Index i = 0; i < x.size(); ++i) y[i] = lhs_diagonal_[i] * x[i] - c * (y[i] - a_diagonal[i] * x[i]);
  };
  last_iterations_ = digilap::detail::conjugate_gradients(apply, inverse_diagonal_, b, next, kCgTolerance, kCgLimit);
  if (last_iterations_ < 0)
    throw Error("MatrixFreeHeatFlow: conjugate gradients did not reach 1e-12 in " + std::to_string(kCgLimit) +
                " iterations (dt is very large against the heat time t); use a smaller dt");
  // Each surface's heat sum mu u, put back exactly by a constant shift (the direction the
  // solve's rounding takes: the constants are the near-kernel of dt A).
  const std::vector<Eigen::Index>& offset = op_.row_offset();
  for (std::size_t p = 0; p + 1 < offset.size(); ++p) {
    const Eigen::Index first = offset[p], count = offset[p + 1] - offset[p];
    const double area = mass.segment(first, count).sum();
    if (!(area > 0)) continue;
    const double change = mass.segment(first, count).dot(next.segment(first, count) - u.segment(first, count));
    next.segment(first, count).array() -= change / area;
  }
  if (!massless_.empty()) {
    // u_i' (1 - theta dt L_ii) = u_i + dt ((1 - theta) (L u)_i + theta sum_{j != i} L_ij u_j'):
    // the u_j' with L_ij != 0 all have area and are known; L_ii = -(row sum of the others).
    Eigen::MatrixXd lu, lnext;
    op_.apply_laplacian(u, lu);
    for (Eigen::Index i : massless_) next[i] = 0;
    op_.apply_laplacian(next, lnext);
    for (Eigen::Index i : massless_) {
      const double lii = -op_.laplacian_row_sums()[i];
      next[i] = (u[i] + dt_ * ((1 - theta_) * lu(i, 0) + theta_ * lnext(i, 0))) / (1 - theta_ * dt_ * lii);
    }
  }
  return next;
}

Eigen::VectorXd MatrixFreeHeatFlow::advance(const Eigen::VectorXd& u0, int steps) const {
  if (steps < 0) throw Error("MatrixFreeHeatFlow::advance: steps must be >= 0");
  Eigen::VectorXd u = u0;
  for (int s = 0; s < steps; ++s) u = step(u);
  return u;
}

Eigen::MatrixXd smooth(const MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& f, double tau, int steps) {
  if (!(tau > 0) || !std::isfinite(tau) || steps < 1) {
    std::ostringstream msg;
    msg << "smoothing: tau must be > 0 and finite and steps >= 1, got tau = " << tau << ", steps = " << steps;
    throw Error(msg.str());
  }
  if (f.rows() != op.rows())
    throw Error("smooth: the functions have " + std::to_string(f.rows()) + " rows, the operator " + std::to_string(op.rows()));
  const MatrixFreeHeatFlow flow(op, tau / steps, TimeScheme::ImplicitEuler);
  Eigen::MatrixXd out(f.rows(), f.cols());
  for (Eigen::Index k = 0; k < f.cols(); ++k) out.col(k) = flow.advance(f.col(k), steps);
  return out;
}

}  // namespace digilap::surface
