#include "digilap/spectrum.hpp"

#include "digilap/error.hpp"
#include "eigen_checks.hpp"

#include <Eigen/SparseCholesky>
#include <Spectra/SymGEigsShiftSolver.h>

#include <cmath>
#include <sstream>

namespace digilap {

namespace {

constexpr double kPi = 3.14159265358979323846;
using ColMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

// y = (-A - sigma M)^{-1} x through a simplicial LDL^T: the natural factorization for this
// symmetric positive definite matrix (Spectra's generic sparse shift-solve uses SparseLU).
class ShiftInvertOp {
public:
  using Scalar = double;
  ShiftInvertOp(const SparseMatrix& A, const Eigen::VectorXd& mass) : minus_A_(-A), mass_(mass) {}
  Eigen::Index rows() const { return mass_.size(); }
  Eigen::Index cols() const { return mass_.size(); }
  void set_shift(double sigma) {
    ColMatrix K = minus_A_;
    for (Eigen::Index i = 0; i < K.outerSize(); ++i) K.coeffRef(i, i) -= sigma * mass_[i];
    solver_.compute(K);
    if (solver_.info() != Eigen::Success)
      throw Error("smallest_eigenpairs: the factorization of -A - sigma M failed (is A negative semidefinite?)");
  }
  void perform_op(const double* x_in, double* y_out) const {
    Eigen::Map<const Eigen::VectorXd> x(x_in, rows());
    Eigen::Map<Eigen::VectorXd> y(y_out, rows());
    y = solver_.solve(x);
  }

private:
  ColMatrix minus_A_;
  Eigen::VectorXd mass_;
  Eigen::SimplicialLDLT<ColMatrix> solver_;
};

// y = M x with M = diag(mass).
class MassOp {
public:
  using Scalar = double;
  explicit MassOp(const Eigen::VectorXd& mass) : mass_(mass) {}
  Eigen::Index rows() const { return mass_.size(); }
  Eigen::Index cols() const { return mass_.size(); }
  void perform_op(const double* x_in, double* y_out) const {
    for (Eigen::Index i = 0; i < mass_.size(); ++i) y_out[i] = mass_[i] * x_in[i];
  }

private:
  const Eigen::VectorXd& mass_;
};

}  // namespace

double heat_kernel_eigenvalue(int m, double P, double t) {
  const double w = 2 * kPi * m / P, w2 = w * w;
  if (t == 0) return w2;
  return -std::expm1(-w2 * t) / t;
}

Spectrum smallest_eigenpairs(const SparseMatrix& A, const Eigen::VectorXd& mass, const SpectrumOptions& o) {
  const Eigen::Index n = mass.size();
  if (A.rows() != n || A.cols() != n)
    throw Error("smallest_eigenpairs: A is " + std::to_string(A.rows()) + "x" + std::to_string(A.cols()) +
                " but there are " + std::to_string(n) + " masses");
  detail::check_eigen_request(mass, o.count);
  // A shift just below 0: -A - sigma M is then definite, and the eigenvalue 0 of each contour
  // stays well separated from the shift relative to the first non-zero one (about (2 pi / P)^2).
  const double sigma = -1e-2 * (2 * kPi / mass.sum()) * (2 * kPi / mass.sum());
  const int ncv = static_cast<int>(std::min<Eigen::Index>(n, o.subspace > 0 ? o.subspace : std::max(2 * o.count + 1, 20)));
  if (ncv <= o.count)
    throw Error("smallest_eigenpairs: the subspace size must exceed count");
  ShiftInvertOp op(A, mass);
  MassOp bop(mass);
  Spectra::SymGEigsShiftSolver<ShiftInvertOp, MassOp, Spectra::GEigsMode::ShiftInvert> eigs(op, bop, o.count, ncv, sigma);
  eigs.init();
  const Eigen::Index converged =
      eigs.compute(Spectra::SortRule::LargestMagn, o.max_iterations, o.tolerance, Spectra::SortRule::SmallestAlge);
  detail::require_converged(eigs, converged, o.count, ncv);
  Spectrum s;
  s.eigenvalues = eigs.eigenvalues();
  s.eigenvectors = eigs.eigenvectors();
  s.iterations = static_cast<int>(eigs.num_iterations());
  s.operations = static_cast<int>(eigs.num_operations());
  return s;
}

Spectrum smallest_eigenpairs(const ContourOperator& op, const SpectrumOptions& options) {
  return smallest_eigenpairs(op.A, op.mass, options);
}

}  // namespace digilap
