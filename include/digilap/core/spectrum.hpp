// digilap — the smallest eigenpairs of a heat operator of any dimension through Spectra (core;
// SPEC §4, §5, §7).
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
//
// Elements of zero mass (mu = 0) have vanishing rows and columns in A: the problem lives on the
// support of mu, and is solved there (every method). Their eigenvector entries are 0 from
// (A, mass) alone; from an operator (smallest_eigenpairs(op)) they are the heat-kernel average
// of their neighbours, their row of L (core/operator.hpp). Spectrum::massless counts them.
#pragma once

#include "digilap/core/operator.hpp"

#include <Eigen/Core>

#include <functional>
#include <limits>
#include <vector>

namespace digilap {

/// How smallest_eigenpairs solves a large part (small ones are dense).
enum class SpectrumMethod {
  /// Factorization (shift-and-invert Lanczos), unless block LOBPCG on products alone converges
  /// within the factorization's own cost, as it does on surfaces (whose factor fills in).
  Auto,
  // (From an operator of dimension >= 2, or with SpectrumOptions::dimension >= 2, Auto means
  // Products: a surface's factorization fills in.)
  /// Shift-and-invert Lanczos on a sparse LDL^T of -A - sigma M (curves: the factor stays a band).
  Factorization,
  /// Block LOBPCG on products with A, no factorization and no symbolic analysis (surfaces: the
  /// spectrum stops near 1 / t, so 21-34 iterations from h = 0.1 to 0.02 on the unit sphere);
  /// falls back to the factorization if it does not converge in max_iterations.
  Products,
};

/// The tolerance of runs that keep eigenvalues alone (digilap-spectrum --labels, Python
/// surface.shape_dna): an eigenvalue errs by about the residual's square over its gap, so on
/// every label of the JHU and Harvard-Oxford atlases the eigenvalues agree with the default's
/// (1e-10) within 3e-11 relative, a few units in the last of the 12 digits spectra.csv prints,
/// in a quarter to a third less time (docs/benchmarks.md). Eigenvectors keep the default: inside
/// a multiplet that the digital surface splits by 1e-3 they err by the residual over that gap.
constexpr double kEigenvaluesOnlyTolerance = 1e-8;

struct SpectrumOptions {
  int count = 10;            ///< number of eigenpairs (smallest first)
  SpectrumMethod method = SpectrumMethod::Auto;  ///< explicit operators: see SpectrumMethod
  int max_iterations = 1000; ///< Lanczos restarts, or LOBPCG iterations, allowed
  /// Relative tolerance, in [1e-14, 1). Lanczos (Spectra): on each Ritz value's residual relative to
  /// it. LOBPCG: every wanted residual |C x - lambda x| (C = M^(-1/2) (-A) M^(-1/2), |x| = 1) at
  /// most tolerance times c, a bound of C's spectrum (Gershgorin, about 2 / t); the eigenvalues
  /// then err by about the residual's square over their gap, the eigenvectors by the residual
  /// over it. Eigenvalues alone (ShapeDNA) need far less than the default: on a torus at
  /// h = 0.025, 1e-6 gives the same eigenvalues within 1e-9 relative in 10 iterations instead
  /// of 16 (docs/benchmarks.md).
  double tolerance = 1e-10;
  /// Krylov subspace size; 0 = max(2 count + 1, 20) for Lanczos (max(4 count, 40) on the
  /// matrix-free path), capped at N
  int subspace = 0;
  /// The manifold's dimension d of (A, M) (1: curves, 2: surfaces): the Lanczos shift is
  /// -1e-2 (2 pi)^2 / (sum mu)^(2/d), a hundredth of the first eigenvalue's order whatever the
  /// units, and Auto means Products for d >= 2. smallest_eigenpairs(op) takes op.dimension.
  int dimension = 1;
  /// The dense blocks LOBPCG may allocate (it holds 7 blocks of N x (count + guards) doubles,
  /// and counts 8; on surfaces, the products' own blocks besides); above it, the factorization
  /// (explicit operators) or Lanczos (matrix-free), else digilap::Error.
  double memory_limit_bytes = 8.0 * (1ull << 30);
  /// Matrix-free surfaces: start LOBPCG from the eigenvectors of the same kernel on aggregates of
  /// about 2 x 2 surfels where that pays (sqrt(t) at least 2 h, 5,000 surfels or more: a third
  /// fewer iterations on smooth surfaces at small h); false: a random start. The same
  /// eigenpairs either way, to the tolerance. Where its eigenvalues show that the block would
  /// end inside the last wanted eigenvalue's cluster (50 eigenpairs of a sphere), the block
  /// goes past it (half the iterations there).
  bool coarse_start = true;
  /// Optional: called after each LOBPCG iteration with the iteration and the largest wanted
  /// residual relative to the tolerance (converged when <= 1).
  std::function<void(int iteration, double residual_over_tolerance)> progress;
};

struct Spectrum {
  Eigen::VectorXd eigenvalues;   ///< ascending, the operator's own (raw) eigenvalues lambda
  /// Laplace-Beltrami estimates, about -ln(1 - lambda t) / t (laplace_beltrami_eigenvalues()
  /// with the operator's cut), filled by the solvers that know t (from an operator); +infinity
  /// where lambda t reaches the kernel's mass (1 without a cut).
  Eigen::VectorXd laplace_beltrami;
  /// How many eigenvalues have lambda t at or above the kernel's mass, where no estimate exists
  /// (0 when all are defined).
  int undefined_estimates = 0;
  Eigen::MatrixXd eigenvectors;  ///< one M-normalized column per eigenvalue
  /// Rows of zero mass: off the support of mu, where the problem was solved (see above).
  Eigen::Index massless = 0;
  int iterations = 0;            ///< Lanczos restarts, or LOBPCG iterations, used (summed over parts)
  int operations = 0;            ///< applications of the shift-inverted operator
};

/// The `count` smallest eigenpairs of -A x = lambda M x, on the support of mu (entries of zero
/// mass rows are 0). Throws digilap::Error when a mass is negative or not finite, when count is
/// not in [1, N_support - 1], or when Spectra does not converge (the message says how many did,
/// and what to try: more iterations, a larger subspace).
Spectrum smallest_eigenpairs(const SparseMatrix& A, const Eigen::VectorXd& mass, const SpectrumOptions& options = {});

/// From an operator of any dimension (op.A, op.mass, op.dimension): also fills the
/// Laplace-Beltrami estimates, each eigenvector's from the heat time of the part it lives on,
/// and gives zero-mass rows the average of their neighbours (their row of op.L). Throws
/// digilap::Error as above, when the operator was assembled without A, or when a zero-mass row
/// has no neighbour with mass within the cut (a part with no mass at all).
Spectrum smallest_eigenpairs(const HeatOperator& op, const SpectrumOptions& options = {});

/// The spectrum of each part (contour, surface) on its own (the natural shape descriptor of each
/// object): element p holds the min(count, n_p) smallest eigenpairs of part p on its n_p rows
/// (row op.row_offset[p] + i of the operator is entry i), n_p counting its rows with mass.
/// Parts are solved in parallel; a part with no mass at all gets an empty spectrum (no
/// eigenvalue, massless = n_p). Throws digilap::Error when parts interact (contours at the
/// Euclidean distance), or as smallest_eigenpairs(op).
std::vector<Spectrum> smallest_eigenpairs_per_part(const HeatOperator& op, const SpectrumOptions& options = {});

/// The kernel whose symbol the Laplace-Beltrami estimates invert: the heat kernel on a manifold
/// of `dimension` (1: contours, 2: surfaces) cut at distance k sqrt(t), as every operator of the
/// library is. k = infinity (the default) is the whole Gaussian, whose symbol does not depend on
/// the dimension.
struct KernelCut {
  int dimension = 2;
  double k = std::numeric_limits<double>::infinity();
};

/// The cut of an operator's kernel: its dimension, and k = cut / sqrt(t).
KernelCut kernel_cut_of(const HeatOperator& op);

/// Undoes the heat kernel's bias on eigenvalues. On a flat manifold the heat-kernel operator
/// with time t has the eigenvalue lambda = F(mu t) / t where the Laplace-Beltrami operator has
/// mu, F(a) = the kernel's mass times (1 - e^(-i omega.y)) averaged, omega^2 = mu (SPEC §5): the
/// whole Gaussian has F(a) = 1 - exp(-a), so mu = -ln(1 - lambda t) / t. A kernel cut at
/// k sqrt(t) has lost the tail of its second moment, (1 + k^2/4) exp(-k^2/4) of it in two
/// dimensions (0.12% at k = 6: every eigenvalue low by that much, whatever h and t, the
/// floor docs/accuracy.md found on the torus), erfc(k/2) + k exp(-k^2/4) / sqrt(pi) in one
/// (0.04%); the estimates invert the cut kernel's F instead (by Newton's method from the whole
/// Gaussian's answer, F's tail by quadrature): mu back to rounding from the flat cut kernel's
/// symbol (tests/core/test_spectrum.cpp integrates that symbol independently).
/// Undefined where lambda t reaches the kernel's mass (the operator's spectrum stops there: 1 /
/// t without a cut): those entries are +infinity, and `undefined` (if given) receives their
/// number. Throws digilap::Error for t not > 0 and finite, a dimension not 1 or 2, or k not > 0.
Eigen::VectorXd laplace_beltrami_eigenvalues(const Eigen::VectorXd& eigenvalues, double t, int* undefined = nullptr,
                                             const KernelCut& kernel = {});

/// The heat kernel signature (Sun, Ovsjanikov, Guibas 2009) of every row at each time tau:
/// HKS(x, tau) = sum_k exp(-lambda_k tau) phi_k(x)^2 over the spectrum's M-orthonormal pairs,
/// lambda_k its Laplace-Beltrami estimates when it has them (an undefined one, +infinity, adds
/// nothing), else its eigenvalues. Returns N x times.size(). Throws digilap::Error for a time
/// not > 0 and finite.
Eigen::MatrixXd heat_kernel_signature(const Spectrum& spectrum, const std::vector<double>& times);

/// `count` times log-spaced from 4 ln 10 / lambda_last to 4 ln 10 / lambda_1 (the signature's
/// usual range: the last mode decayed to 1e-4, the first just starting), lambda_1 the first
/// non-zero eigenvalue. Throws digilap::Error when the spectrum has no non-zero eigenvalue.
std::vector<double> heat_kernel_signature_times(const Spectrum& spectrum, int count = 5);

}  // namespace digilap
