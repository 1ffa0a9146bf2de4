// One implicit heat step (M - dt A) u' = M u on the matrix-free contour operator by conjugate
// gradients, through Eigen's matrix-free solver interface.
#include "digilap/curve/matrix_free.hpp"

#include "digilap/core/error.hpp"

#include <Eigen/IterativeLinearSolvers>

#include <cmath>
#include <sstream>

// --- Conjugate gradient on the matrix-free operator ------------------------------------------
// Eigen's iterative solvers accept any matrix type that provides a product with a vector: the
// wrapper below is (M - dt A) applied through MatrixFreeLaplacian (Eigen's "matrix-free solvers").

namespace digilap {
inline namespace curve {
class HeatStepMatrix;
}  // namespace curve
}  // namespace digilap

namespace Eigen::internal {
template <>
struct traits<digilap::HeatStepMatrix> : public traits<Eigen::SparseMatrix<double>> {};
}  // namespace Eigen::internal

namespace digilap {
inline namespace curve {

class HeatStepMatrix : public Eigen::EigenBase<HeatStepMatrix> {
public:
  using Scalar = double;
  using RealScalar = double;
  using StorageIndex = int;
  enum { ColsAtCompileTime = Eigen::Dynamic, MaxColsAtCompileTime = Eigen::Dynamic, IsRowMajor = false };
  HeatStepMatrix(const MatrixFreeLaplacian& op, double dt) : op_(op), dt_(dt) {}
  Eigen::Index rows() const { return op_.rows(); }
  Eigen::Index cols() const { return op_.rows(); }
  template <typename Rhs>
  Eigen::Product<HeatStepMatrix, Rhs, Eigen::AliasFreeProduct> operator*(const Eigen::MatrixBase<Rhs>& x) const {
    return Eigen::Product<HeatStepMatrix, Rhs, Eigen::AliasFreeProduct>(*this, x.derived());
  }
  // (M - dt M L) x = M (x - dt L x)
  Eigen::VectorXd multiply(const Eigen::VectorXd& x) const { return op_.mass().cwiseProduct(x - dt_ * (op_ * x)); }
  // Jacobi: the diagonal of M - dt A is mu_i (1 - dt L_ii).
  Eigen::VectorXd diagonal_values() const {
    return op_.mass().cwiseProduct((Eigen::VectorXd::Ones(rows()) - dt_ * op_.diagonal()));
  }

private:
  const MatrixFreeLaplacian& op_;
  double dt_;
};

/// Jacobi preconditioner from the wrapper's diagonal (Eigen's DiagonalPreconditioner needs
/// stored coefficients).
class JacobiPreconditioner {
public:
  JacobiPreconditioner() = default;
  template <typename M>
  explicit JacobiPreconditioner(const M& m) { compute(m); }
  template <typename M>
  JacobiPreconditioner& analyzePattern(const M&) { return *this; }
  template <typename M>
  JacobiPreconditioner& factorize(const M& m) { return compute(m); }
  template <typename M>
  JacobiPreconditioner& compute(const M& m) {
    inverse_ = m.diagonal_values().cwiseInverse();
    return *this;
  }
  template <typename Rhs>
  Eigen::VectorXd solve(const Rhs& b) const { return inverse_.cwiseProduct(b); }
  Eigen::ComputationInfo info() const { return Eigen::Success; }

private:
  Eigen::VectorXd inverse_;
};

}  // namespace curve
}  // namespace digilap

namespace Eigen::internal {
template <typename Rhs>
struct generic_product_impl<digilap::HeatStepMatrix, Rhs, SparseShape, DenseShape, GemvProduct>
    : generic_product_impl_base<digilap::HeatStepMatrix, Rhs, generic_product_impl<digilap::HeatStepMatrix, Rhs>> {
  using Scalar = typename Product<digilap::HeatStepMatrix, Rhs>::Scalar;
  template <typename Dest>
  static void scaleAndAddTo(Dest& dst, const digilap::HeatStepMatrix& lhs, const Rhs& rhs, const Scalar& alpha) {
    dst.noalias() += alpha * lhs.multiply(rhs);
  }
};
}  // namespace Eigen::internal

namespace digilap {
inline namespace curve {

Eigen::VectorXd heat_step_cg(const MatrixFreeLaplacian& op, const Eigen::VectorXd& u, double dt, double tolerance,
                             int* iterations) {
  require_positive("heat_step_cg: dt", dt);
  if (u.size() != op.rows()) throw Error("heat_step_cg: the vector has the wrong size");
  for (Eigen::Index i = 0; i < op.rows(); ++i)
    if (!(op.mass()[i] > 0)) throw Error("heat_step_cg: the mass of row " + std::to_string(i) + " is not > 0");
  const HeatStepMatrix K(op, dt);
  Eigen::ConjugateGradient<HeatStepMatrix, Eigen::Lower | Eigen::Upper, JacobiPreconditioner> cg;
  cg.setTolerance(tolerance);
  cg.setMaxIterations(1000);
  cg.compute(K);
  const Eigen::VectorXd next = cg.solveWithGuess(op.mass().cwiseProduct(u), u);
  if (iterations) *iterations = static_cast<int>(cg.iterations());
  if (cg.info() != Eigen::Success) {
    std::ostringstream msg;
    msg << "heat_step_cg: conjugate gradient did not converge (" << cg.iterations() << " iterations, error "
        << cg.error() << ")";
    throw Error(msg.str());
  }
  return next;
}

}  // namespace curve
}  // namespace digilap
