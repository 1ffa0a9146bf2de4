// digilap — heat flow and smoothing on the matrix-free surface operator (issue 23): the
// schemes of HeatFlow (core/heat_flow.hpp), each step solved by conjugate gradients on products, so
// memory stays O(N) where the assembled operator would take k^2 pi t / h^2 nonzeros a row.
//
// A step solves (M - theta dt A) u' = M u + (1 - theta) dt A u by Jacobi-preconditioned CG
// from u (to 1e-12 relative residual), about 2 + (iterations) products. Surfels of zero area
// follow their row of L, as in HeatFlow(op); the heat sum mu u of each surface is kept to
// rounding. The products are bitwise thread-independent, and so is the flow.
#pragma once

#include "digilap/core/heat_flow.hpp"
#include "digilap/surface/matrix_free.hpp"

#include <Eigen/Core>

namespace digilap::surface {

class MatrixFreeHeatFlow {
public:
  /// Keeps a reference to op, which must outlive the flow (as Eigen's iterative solvers keep
  /// their matrix). Throws digilap::Error for dt not > 0 and finite, or a zero-area surfel with
  /// no neighbour of non-zero area within the cut.
  MatrixFreeHeatFlow(const MatrixFreeSurfaceOperator& op, double dt, TimeScheme scheme = TimeScheme::CrankNicolson);

  double dt() const { return dt_; }
  /// One step from u. Throws digilap::Error for a size mismatch or CG not converging.
  Eigen::VectorXd step(const Eigen::VectorXd& u) const;
  /// `steps` steps from u0, i.e. to time steps * dt.
  Eigen::VectorXd advance(const Eigen::VectorXd& u0, int steps) const;
  /// Conjugate-gradient iterations of the last step.
  int last_iterations() const { return last_iterations_; }

private:
  Eigen::VectorXd stiffness(const Eigen::VectorXd& x) const;
  const MatrixFreeSurfaceOperator& op_;
  double dt_, theta_;
  Eigen::VectorXd lhs_diagonal_, inverse_diagonal_;  // of M - theta dt A (1 on zero-area rows)
  std::vector<Eigen::Index> massless_;
  mutable int last_iterations_ = 0;
};

/// Columns of f diffused for time tau by implicit Euler in `steps` steps on the matrix-free
/// operator (core/smoothing.hpp's smooth, without storing L). Throws digilap::Error for tau not > 0
/// and finite, steps < 1, a size mismatch, or as MatrixFreeHeatFlow.
Eigen::MatrixXd smooth(const MatrixFreeSurfaceOperator& op, const Eigen::MatrixXd& f, double tau, int steps = 1);

}  // namespace digilap::surface
