// digilap (internal) — preconditioned conjugate gradients for the symmetric positive definite
// step systems of the heat flow, any dimension, assembled or matrix-free (core).
//
// Written here rather than taken from Eigen's ConjugateGradient: the product is the caller's
// (a sparse row loop, or the matrix-free surface operator), and the result must not depend on
// the number of threads: the dot products and updates below run in one fixed order, so the
// iterates are the same bits whenever the product is.
#pragma once

#include <Eigen/Core>

namespace digilap::detail {

/// Solves S x = b for S symmetric positive definite, given y = S x by `apply(x, y)` and the
/// inverse of S's diagonal (Jacobi preconditioner), from the guess in x, until
/// |r| <= relative_tolerance |b|. Returns the iterations taken, or -1 when max_iterations did
/// not reach the tolerance (x then holds the last iterate).
template <class Apply>
int conjugate_gradients(const Apply& apply, const Eigen::VectorXd& inverse_diagonal, const Eigen::VectorXd& b,
                        Eigen::VectorXd& x, double relative_tolerance, int max_iterations) {
  const Eigen::Index n = b.size();
  Eigen::VectorXd r(n), z(n), p(n), q(n);
  apply(x, q);
  r = b - q;
  const double stop = relative_tolerance * b.norm();
  z = inverse_diagonal.cwiseProduct(r);
  p = z;
  double rz = r.dot(z);
  for (int k = 0; k < max_iterations; ++k) {
    if (r.norm() <= stop) return k;
    apply(p, q);
    const double alpha = rz / p.dot(q);
    x += alpha * p;
    r -= alpha * q;
    z = inverse_diagonal.cwiseProduct(r);
    const double rz_next = r.dot(z);
    p = z + (rz_next / rz) * p;
    rz = rz_next;
  }
  return r.norm() <= stop ? max_iterations : -1;
}

}  // namespace digilap::detail
