// Internal: symmetric positive definite cyclic tridiagonal systems (a path closed into a
// loop: the 1D Laplacian along a closed contour, plus a mass term). Written here because
// Eigen has no banded or cyclic solver; its sparse LDLT on this matrix solved a block of 15
// right-hand sides in 63 ms at N = 2e5 (fill-reducing permutations, one column at a time
// through sparse triangles), this in a few.
//
// A = L D L^T with L unit lower triangular, nonzero on the first subdiagonal and on the last
// row (the corner entry A(n-1, 0) fills that row in): O(n) to factorize, 3n numbers, and a
// solve is two sweeps of O(n). No pivoting: A is positive definite.
#pragma once

#include <Eigen/Core>

namespace digilap::detail {

class CyclicTridiagonalLDLT {
public:
  /// A(i, i) = diagonal[i], A(i, i + 1 mod n) = A(i + 1 mod n, i) = coupling[i]; n >= 3.
  /// Throws digilap::Error when n < 3, the sizes differ, or A is not positive definite (a
  /// pivot below 1e-10 of its diagonal entry counts as singular).
  CyclicTridiagonalLDLT(const Eigen::VectorXd& diagonal, const Eigen::VectorXd& coupling);

  Eigen::Index size() const { return d_.size(); }

  /// column <- A^-1 column (n values).
  void solve_in_place(double* column) const;

private:
  Eigen::VectorXd d_;     // D
  Eigen::VectorXd sub_;   // sub_[i] = L(i, i - 1), i = 1 .. n - 2
  Eigen::VectorXd last_;  // last_[j] = L(n - 1, j), j = 0 .. n - 2
};

}  // namespace digilap::detail
