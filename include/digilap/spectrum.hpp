// digilap — the smallest eigenpairs of the operator through Spectra (SPEC §4, §5).
//
// Solves the generalized problem  -A x = lambda M x  (A = M L symmetric negative semidefinite,
// M = diag(mu)) for its smallest eigenvalues, ascending, by Lanczos in shift-and-invert mode
// with a sparse Cholesky (LDL^T) factorization of -A - sigma M, sigma slightly negative, or by
// block LOBPCG on products when the factorization would fill in (surfaces; SpectrumMethod).
// Eigenvectors are M-orthonormal: x_i^T M x_j = delta_ij, with a fixed sign (the entry of
// largest magnitude is positive). Each closed contour contributes one eigenvalue 0 (its
// constant vector).
//
// Repeated eigenvalues are all returned. The operator falls into connected components (one per
// contour in geodesic mode) whose spectra make up the whole one, with multiplicities: ten
// identical contours give every eigenvalue ten times, which a Krylov solver run on the whole
// would see once. So each component is solved on its own (densely up to 400 rows, in parallel
// when there are several) and the results merged; a component's Lanczos answer is checked by
// the inertia of -A - sigma M (the number of eigenvalues below sigma) and recomputed when it
// skipped a copy.
#pragma once

#include "digilap/heat_laplacian.hpp"

#include <Eigen/Core>

#include <functional>
#include <vector>

namespace digilap {

/// How smallest_eigenpairs solves a large part (small ones are dense).
enum class SpectrumMethod {
  /// Factorization (shift-and-invert Lanczos), unless block LOBPCG on products alone converges
  /// within the factorization's own cost, as it does on surfaces (whose factor fills in).
  Auto,
  /// Shift-and-invert Lanczos on a sparse LDL^T of -A - sigma M (curves: the factor stays a band).
  Factorization,
  /// Block LOBPCG on products with A, no factorization and no symbolic analysis (surfaces: the
  /// spectrum stops near 1 / t, so 21-34 iterations from h = 0.1 to 0.02 on the unit sphere);
  /// falls back to the factorization if it does not converge in max_iterations.
  Products,
};

struct SpectrumOptions {
  int count = 10;            ///< number of eigenpairs (smallest first)
  SpectrumMethod method = SpectrumMethod::Auto;  ///< explicit operators: see SpectrumMethod
  int max_iterations = 1000; ///< Lanczos restarts, or LOBPCG iterations, allowed
  double tolerance = 1e-10;  ///< relative tolerance on the Ritz values
  int subspace = 0;          ///< Krylov subspace size; 0 = max(2 count + 1, 20), capped at N
  /// Matrix-free solver only: the dense blocks it may allocate (LOBPCG holds about 16 blocks
  /// of N x (count + guard) doubles); above it, Lanczos (N x subspace), else digilap::Error.
  double memory_limit_bytes = 8.0 * (1ull << 30);
  /// Matrix-free solver only, optional: called after each LOBPCG iteration with the iteration
  /// and the largest wanted residual relative to the tolerance (converged when <= 1).
  std::function<void(int iteration, double residual_over_tolerance)> progress;
};

struct Spectrum {
  Eigen::VectorXd eigenvalues;   ///< ascending, the operator's own (raw) eigenvalues lambda
  /// Laplace-Beltrami estimates -ln(1 - lambda t) / t (see laplace_beltrami_eigenvalues()),
  /// filled by the solvers that know t (from an operator); +infinity where lambda t >= 1.
  Eigen::VectorXd laplace_beltrami;
  /// How many eigenvalues have lambda t >= 1, where no estimate exists (0 when all are defined).
  int undefined_estimates = 0;
  Eigen::MatrixXd eigenvectors;  ///< one M-normalized column per eigenvalue
  int iterations = 0;            ///< Lanczos restarts used
  int operations = 0;            ///< applications of the shift-inverted operator
};

/// The `count` smallest eigenpairs of -A x = lambda M x. Throws digilap::Error when a mass is
/// not > 0 (M must be definite: use pointels, or a smaller k_R), when count is not in
/// [1, N - 1], or when Spectra does not converge (the message says how many did, and what to
/// try: more iterations, a larger subspace).
Spectrum smallest_eigenpairs(const SparseMatrix& A, const Eigen::VectorXd& mass, const SpectrumOptions& options = {});

/// Convenience: from an operator (uses op.A and op.mass).
Spectrum smallest_eigenpairs(const ContourOperator& op, const SpectrumOptions& options = {});

/// The spectrum of each contour on its own (the natural shape descriptor of each object of an
/// image): element c holds the min(count, n_c) smallest eigenpairs of contour c, on its n_c
/// rows (row op.row_offset[c] + i of the operator is entry i). Contours are solved in
/// parallel. Throws digilap::Error when contours interact (Euclidean distance), or when a mass
/// is not > 0.
std::vector<Spectrum> smallest_eigenpairs_per_contour(const ContourOperator& op, const SpectrumOptions& options = {});

/// Undoes the heat kernel's bias on eigenvalues: the heat-kernel operator with time t has
/// eigenvalues lambda = (1 - exp(-mu t)) / t where the Laplace-Beltrami operator has mu (SPEC
/// §5; exact on a closed curve's spectrum, to 2e-4 on digital contours), so mu = -ln(1 - lambda
/// t) / t. Undefined for lambda t >= 1 (the operator's spectrum stops at 1 / t): those entries
/// are +infinity, and `undefined` (if given) receives their number. Throws digilap::Error for t
/// not > 0 and finite.
Eigen::VectorXd laplace_beltrami_eigenvalues(const Eigen::VectorXd& eigenvalues, double t, int* undefined = nullptr);

/// The heat-kernel operator's eigenvalues on a closed curve of length P with heat time t:
/// (1 - exp(-omega^2 t)) / t, omega = 2 pi m / P (SPEC §5). With t = 0: omega^2 exactly.
double heat_kernel_eigenvalue(int m, double P, double t);

}  // namespace digilap
