// Internal: block LOBPCG (Knyazev 2001) for the smallest eigenpairs of a symmetric operator C
// given only as block products, with a symmetric positive definite preconditioner T ~ C^-1.
// Written here because Spectra's LOBPCG (contrib) needs C as a stored sparse matrix, and the
// point of this solver is the matrix-free operator.
//
// Each iteration: residuals R = C X - X Lambda, W = T R made orthogonal to X and P and
// orthonormal, Rayleigh-Ritz on the orthonormal basis [X, W, P] (the eigenproblem of S^T C S
// alone), the next P = the W, P part of the new X made orthogonal to it and orthonormal in
// coordinates (Hetmaniuk and Lehoucq 2006, "Basis selection in LOBPCG"). One block product per
// iteration.
//
// Memory: the basis [Q X P W] and its image in two N x 3b blocks, the residuals in one N x b
// (7 blocks in all, 11 before 2026-12-07). The operator and the preconditioner write into views
// of those blocks (BlockMap's out), and every update of X, P and W is made in place, a chunk of
// rows at a time: at h = 0.0125 on a torus with 50 eigenpairs each block is 72 MB.
#pragma once

#include <Eigen/Core>

#include <functional>

namespace digilap::detail {

/// out = the operator applied to in, column by column. `out` is a view of the solver's own
/// blocks, of in's size (never resized); it does not overlap `in`.
using BlockIn = Eigen::Ref<const Eigen::MatrixXd>;
using BlockOut = Eigen::Ref<Eigen::MatrixXd>;
using BlockMap = std::function<void(const BlockIn& in, BlockOut out)>;

struct LobpcgResult {
  Eigen::VectorXd values;   ///< ascending, `count` of them
  Eigen::MatrixXd vectors;  ///< orthonormal columns
  Eigen::VectorXd residual_norms;
  int iterations = 0;
  int products = 0;         ///< columns multiplied by C
  bool converged = false;
};

/// The `count` smallest eigenpairs of C, iterating a block of start.cols() >= count vectors
/// until every wanted residual norm ||C x - lambda x|| is <= tolerance (absolute), or
/// max_iterations.
/// `progress`, if set, gets each iteration and its largest wanted residual / tolerance.
/// With `with_guards`, values, vectors and residual_norms go on past the `count` wanted with
/// the block's other Ritz pairs (the guards: approximations that did not have to converge).
LobpcgResult lobpcg(const BlockMap& apply_c, const BlockMap& apply_t, Eigen::MatrixXd start, int count,
                    double tolerance, int max_iterations,
                    const std::function<void(int, double)>& progress = nullptr, bool with_guards = false);

/// The block for `count` eigenpairs of n rows: `count` plus guard vectors, which speed up the
/// last wanted ones, half as many as wanted between 4 and 10. More guards save iterations but
/// not time: the dense algebra of an iteration grows as the block's square, and beyond 10 it
/// outweighs the iterations saved (JHU 1 mm label 1, 50 eigenpairs, 1 thread: 25 guards 22
/// iterations 2.16 s, 10 guards 28 iterations 1.73 s; the torus at h = 0.025, 50 eigenpairs:
/// 6.2 s / 397 MB against 5.9 s / 323 MB; docs/benchmarks.md).
inline Eigen::Index lobpcg_block(Eigen::Index n, int count) {
  const int guards = count / 2 < 4 ? 4 : count / 2 > 10 ? 10 : count / 2;
  return n < count + guards ? n : count + guards;
}

/// The block for `count` eigenpairs when estimates of the smallest eigenvalues are known
/// (ascending, past the usual `block`: a coarse problem's, its guards' included), so that the
/// block ends at a gap: LOBPCG's last wanted pairs converge at a rate set by the ratio of the
/// last wanted eigenvalue to the first one past the block.
/// - Where the usual block ends inside the last wanted eigenvalue's cluster (the first past it
///   within 10% of it), it grows to the first estimate 10% above the last wanted one, when that
///   is within max_block (else stays).
/// - Otherwise it drops its last columns whose estimates are within 2% of the first one past it:
///   they leave the gap where it was and cost a column in every product.
/// Returns block when the estimates do not reach past it.
Eigen::Index block_at_a_gap(const Eigen::VectorXd& estimates, int count, Eigen::Index block, Eigen::Index max_block);

/// A fixed pseudo-random start block (entries in [-0.5, 0.5)): reproducible runs.
Eigen::MatrixXd lobpcg_start(Eigen::Index n, Eigen::Index b);

/// Bytes of the dense blocks lobpcg() holds for n rows and a block of b columns: the basis
/// [Q X P W] and its image (6 b), the residuals (b), and the start or the result (b).
inline double lobpcg_bytes(Eigen::Index n, Eigen::Index b) { return 8.0 * static_cast<double>(n) * b * sizeof(double); }

}  // namespace digilap::detail
