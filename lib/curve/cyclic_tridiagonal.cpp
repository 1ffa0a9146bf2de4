#include "cyclic_tridiagonal.hpp"

#include "digilap/core/error.hpp"

#include <cmath>
#include <string>

namespace digilap::detail {

CyclicTridiagonalLDLT::CyclicTridiagonalLDLT(const Eigen::VectorXd& diagonal, const Eigen::VectorXd& coupling) {
  const Eigen::Index n = diagonal.size();
  if (n < 3 || coupling.size() != n)
    throw Error("CyclicTridiagonalLDLT: needs n >= 3 and as many couplings as diagonal entries, got " +
                std::to_string(n) + " and " + std::to_string(coupling.size()));
  d_.resize(n);
  sub_ = Eigen::VectorXd::Zero(n);
  last_ = Eigen::VectorXd::Zero(n);
  // Rows 0 .. n-2 are a plain tridiagonal LDL^T.
  d_[0] = diagonal[0];
  for (Eigen::Index i = 1; i < n - 1; ++i) {
    sub_[i] = coupling[i - 1] / d_[i - 1];
    d_[i] = diagonal[i] - sub_[i] * coupling[i - 1];
  }
  // The last row: A(n-1, j) = sum_k L(n-1, k) D_k L(j, k) = last_j D_j + last_(j-1) D_(j-1) sub_j,
  // with A(n-1, 0) the corner coupling and A(n-1, n-2) the last subdiagonal one.
  double d_last = diagonal[n - 1];
  for (Eigen::Index j = 0; j < n - 1; ++j) {
    double a = (j == 0 ? coupling[n - 1] : 0.0) + (j == n - 2 ? coupling[n - 2] : 0.0);
    if (j > 0) a -= last_[j - 1] * d_[j - 1] * sub_[j];
    last_[j] = a / d_[j];
    d_last -= last_[j] * last_[j] * d_[j];
  }
  d_[n - 1] = d_last;
  // A pivot <= 0 (or NaN) means A is not positive definite; one below 1e-10 of its diagonal
  // entry, that A is singular up to rounding (a singular A leaves a pivot of about n eps):
  // either way the solve would be meaningless.
  for (Eigen::Index i = 0; i < n; ++i)
    if (!(d_[i] > 1e-10 * std::abs(diagonal[i])))
      throw Error("CyclicTridiagonalLDLT: the matrix is not positive definite (pivot " + std::to_string(i) + ")");
}

void CyclicTridiagonalLDLT::solve_in_place(double* x) const {
  const Eigen::Index n = d_.size();
  // L y = b
  double last = x[n - 1] - last_[0] * x[0];
  for (Eigen::Index i = 1; i < n - 1; ++i) {
    x[i] -= sub_[i] * x[i - 1];
    last -= last_[i] * x[i];
  }
  x[n - 1] = last;
  // D z = y, then L^T x = z
  x[n - 1] /= d_[n - 1];
  const double x_last = x[n - 1];
  x[n - 2] = x[n - 2] / d_[n - 2] - last_[n - 2] * x_last;
  for (Eigen::Index i = n - 3; i >= 0; --i) x[i] = x[i] / d_[i] - sub_[i + 1] * x[i + 1] - last_[i] * x_last;
}

}  // namespace digilap::detail
