#include "lobpcg.hpp"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace digilap::detail {

namespace {

// Coordinates of an orthonormal basis of span(S), from S's Gram matrix alone: columns scaled
// to unit norm (the Gram matrix then measures dependence, not size), eigen-decomposition
// V D V^T, directions with D below 1e-12 of the largest dropped (they would amplify rounding
// by more than 1e6), map = diag(1 / |s_k|) V D^(-1/2). S map is then orthonormal.
Eigen::MatrixXd orthonormal_coordinates(const Eigen::MatrixXd& gram) {
  Eigen::VectorXd inv_norms = gram.diagonal().cwiseSqrt();
  for (Eigen::Index k = 0; k < inv_norms.size(); ++k) inv_norms[k] = inv_norms[k] > 0 ? 1.0 / inv_norms[k] : 0.0;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(inv_norms.asDiagonal() * gram * inv_norms.asDiagonal());
  const Eigen::VectorXd& d = eig.eigenvalues();
  const double floor = 1e-12 * d.maxCoeff();
  Eigen::Index first = 0;
  while (first < d.size() && d[first] <= floor) ++first;
  const Eigen::Index kept = d.size() - first;
  Eigen::MatrixXd map = inv_norms.asDiagonal() * eig.eigenvectors().rightCols(kept);
  for (Eigen::Index k = 0; k < kept; ++k) map.col(k) /= std::sqrt(d[first + k]);
  return map;
}

// Rayleigh-Ritz on span(S), given S^T S and S^T C S: the `keep` smallest Ritz values, and the
// coordinates in S of their Ritz vectors.
struct RitzPairs {
  Eigen::VectorXd values;
  Eigen::MatrixXd coordinates;
};
RitzPairs rayleigh_ritz(const Eigen::MatrixXd& gram, const Eigen::MatrixXd& projected, Eigen::Index keep) {
  const Eigen::MatrixXd map = orthonormal_coordinates(gram);
  Eigen::MatrixXd h = map.transpose() * projected * map;
  h = 0.5 * (h + h.transpose());  // symmetric up to rounding: made exactly so
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(h);
  keep = std::min<Eigen::Index>(keep, h.rows());
  return {eig.eigenvalues().head(keep), map * eig.eigenvectors().leftCols(keep)};
}

}  // namespace

LobpcgResult lobpcg(const BlockMap& apply_c, const BlockMap& apply_t, Eigen::MatrixXd start, int count,
                    double tolerance, int max_iterations, const std::function<void(int, double)>& progress) {
  LobpcgResult result;
  const Eigen::Index n = start.rows(), b = start.cols();
  // Every N-row block is allocated once, here: at large N a fresh block per iteration cost
  // more in first-touch page faults than the arithmetic (N = 7e5: about 250 MB each).
  // The basis [X | W | P] and its image live side by side in s and cs.
  Eigen::MatrixXd s(n, 3 * b), cs(n, 3 * b), r(n, b), w(n, b), cw(n, b), p(n, 0), cp(n, 0);
  Eigen::MatrixXd next_x(n, b), next_cx(n, b), next_p(n, b), next_cp(n, b);
  apply_c(start, cw);
  result.products += static_cast<int>(b);
  RitzPairs ritz = rayleigh_ritz(start.transpose() * start, start.transpose() * cw, b);
  Eigen::Index bx = ritz.values.size();
  s.leftCols(bx).noalias() = start * ritz.coordinates;
  cs.leftCols(bx).noalias() = cw * ritz.coordinates;
  start.resize(0, 0);
  Eigen::VectorXd lambda = ritz.values;
  for (int iteration = 0;; ++iteration) {
    const auto x = s.leftCols(bx), cx = cs.leftCols(bx);
    r.resize(n, bx);  // no-op unless Rayleigh-Ritz dropped directions
    r.noalias() = cx - x * lambda.asDiagonal();
    result.residual_norms = r.colwise().norm().transpose();
    result.iterations = iteration;
    if (progress) progress(iteration, result.residual_norms.head(std::min<Eigen::Index>(count, bx)).maxCoeff() / tolerance);
    if (bx >= count && (result.residual_norms.head(count).array() <= tolerance).all()) {
      result.converged = true;
      break;
    }
    if (iteration == max_iterations) break;
    // Preconditioned residuals, made orthogonal to X (twice: once is not enough in floating
    // point when X has nearly converged), then multiplied by C.
    apply_t(r, w);
    for (int pass = 0; pass < 2; ++pass) {
      const Eigen::MatrixXd overlap = x.transpose() * w;
      w.noalias() -= x * overlap;
    }
    apply_c(w, cw);
    result.products += static_cast<int>(w.cols());
    // Rayleigh-Ritz on [X, W, P]; only S^T S and S^T C S are formed (no orthonormalized copy).
    const Eigen::Index bw = w.cols(), bp = p.cols(), cols = bx + bw + bp;
    s.middleCols(bx, bw) = w;
    cs.middleCols(bx, bw) = cw;
    s.middleCols(bx + bw, bp) = p;
    cs.middleCols(bx + bw, bp) = cp;
    const auto basis = s.leftCols(cols), image = cs.leftCols(cols);
    ritz = rayleigh_ritz(basis.transpose() * basis, basis.transpose() * image, b);
    const Eigen::Index keep = ritz.values.size(), tail = cols - bx;
    // New X, and P = its part along W and P, formed as that combination: X_new - X c_x would
    // be the same in exact arithmetic, but it cancels as X converges and leaves P and C P
    // inconsistent (the iteration then diverges; seen at residuals near 1e-6).
    for (Eigen::MatrixXd* m : {&next_x, &next_cx, &next_p, &next_cp}) m->resize(n, keep);
    next_p.noalias() = basis.rightCols(tail) * ritz.coordinates.bottomRows(tail);
    next_cp.noalias() = image.rightCols(tail) * ritz.coordinates.bottomRows(tail);
    next_x.noalias() = basis * ritz.coordinates;
    next_cx.noalias() = image * ritz.coordinates;
    s.leftCols(keep) = next_x;
    cs.leftCols(keep) = next_cx;
    p.swap(next_p);
    cp.swap(next_cp);
    bx = keep;
    lambda = ritz.values;
  }
  result.values = lambda.head(std::min<Eigen::Index>(count, lambda.size()));
  result.vectors = s.leftCols(result.values.size());
  return result;
}

}  // namespace digilap::detail
