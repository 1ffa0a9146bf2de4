#include "lobpcg.hpp"

#include "huge_pages.hpp"
#include "tall_products.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace digilap::detail {

namespace {

// Dense block algebra whose result does not depend on the number of threads. Eigen's parallel
// products block their sums by the thread count, which changed the last bits of the Ritz
// values, hence signs and rotations inside near-degenerate pairs (eigenvectors differed by up
// to 0.69 between 1 and 2 threads). Here rows are cut into chunks of a fixed size, each
// multiplied on one thread (tall_products.hpp: vectorized for the CPU, where Eigen's products
// are built for SSE2), and the partial sums added in chunk order.
constexpr Eigen::Index kChunkRows = 2048;
using ConstBlock = Eigen::Ref<const Eigen::MatrixXd>;

Eigen::Index chunk_count(Eigen::Index n) { return (n + kChunkRows - 1) / kChunkRows; }

// The sum over row chunks of product(first, rows, partial), each partial a rows_out x
// cols_out matrix (zero to start with) computed on one thread.
template <typename ChunkProduct>
Eigen::MatrixXd sum_over_chunks(Eigen::Index n, Eigen::Index rows_out, Eigen::Index cols_out,
                                const ChunkProduct& product) {
  const Eigen::Index chunks = chunk_count(n);
  std::vector<Eigen::MatrixXd> partial(static_cast<std::size_t>(chunks));
#pragma omp parallel for schedule(static)
  for (Eigen::Index k = 0; k < chunks; ++k) {
    const Eigen::Index first = k * kChunkRows, rows = std::min(kChunkRows, n - first);
    partial[k] = Eigen::MatrixXd::Zero(rows_out, cols_out);
    product(first, rows, partial[k]);
  }
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(rows_out, cols_out);
  for (const Eigen::MatrixXd& p : partial) sum += p;
  return sum;
}

// x^T y
Eigen::MatrixXd gram(const ConstBlock& x, const ConstBlock& y) {
  return sum_over_chunks(x.rows(), x.cols(), y.cols(), [&](Eigen::Index first, Eigen::Index rows, Eigen::MatrixXd& out) {
    tall_gram(x.middleRows(first, rows), y.middleRows(first, rows), out);
  });
}

// x^T y when that is symmetric (y = x, or y = C x with C symmetric), from the blocks on and
// above its diagonal: y's columns fall into blocks ending at `ends`, and the blocks below the
// diagonal are the transposes of those above. For three equal blocks, 6 of the 9 products.
Eigen::MatrixXd symmetric_gram(const ConstBlock& x, const ConstBlock& y, const std::vector<Eigen::Index>& ends) {
  const Eigen::Index cols = x.cols();
  Eigen::MatrixXd sum = sum_over_chunks(x.rows(), cols, cols, [&](Eigen::Index first, Eigen::Index rows, Eigen::MatrixXd& out) {
    Eigen::Index begin = 0;
    for (const Eigen::Index end : ends) {
      if (end > begin)
        tall_gram(x.middleRows(first, rows).leftCols(end), y.middleRows(first, rows).middleCols(begin, end - begin),
                  out.block(0, begin, end, end - begin));
      begin = end;
    }
  });
  std::vector<int> block_of(static_cast<std::size_t>(cols));
  for (Eigen::Index c = 0, b = 0; c < cols; ++c) {
    while (c >= ends[static_cast<std::size_t>(b)]) ++b;
    block_of[static_cast<std::size_t>(c)] = static_cast<int>(b);
  }
  for (Eigen::Index j = 0; j < cols; ++j)
    for (Eigen::Index i = 0; i < cols; ++i)
      if (block_of[static_cast<std::size_t>(i)] > block_of[static_cast<std::size_t>(j)]) sum(i, j) = sum(j, i);
  return sum;
}

// out = x c (out resized to x.rows() x c.cols(); not aliased with x)
void combine(const ConstBlock& x, const Eigen::MatrixXd& c, Eigen::MatrixXd& out) {
  out.resize(x.rows(), c.cols());
  const Eigen::Index chunks = chunk_count(x.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index k = 0; k < chunks; ++k) {
    const Eigen::Index first = k * kChunkRows, rows = std::min(kChunkRows, x.rows() - first);
    tall_product(x.middleRows(first, rows), c, out.middleRows(first, rows), false);
  }
}

// out -= x c (not aliased with x)
void subtract_combination(const ConstBlock& x, const Eigen::MatrixXd& c, Eigen::MatrixXd& out) {
  const Eigen::Index chunks = chunk_count(x.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index k = 0; k < chunks; ++k) {
    const Eigen::Index first = k * kChunkRows, rows = std::min(kChunkRows, x.rows() - first);
    tall_product(x.middleRows(first, rows), c, out.middleRows(first, rows), true);
  }
}

// The c.cols() columns of m from `first` on <- (its c.rows() columns from `first` on) c + add.
// In place, chunk by chunk of rows: a chunk's product reads only its own rows, so it may
// overwrite them (no N-row temporary to fault in and copy back).
void combine_in_place(Eigen::MatrixXd& m, Eigen::Index first_col, const Eigen::MatrixXd& c, const Eigen::MatrixXd& add) {
  const Eigen::Index chunks = chunk_count(m.rows());
#pragma omp parallel
  {
    Eigen::MatrixXd product;  // one chunk, reused by the thread
#pragma omp for schedule(static)
    for (Eigen::Index k = 0; k < chunks; ++k) {
      const Eigen::Index first = k * kChunkRows, rows = std::min(kChunkRows, m.rows() - first);
      product.resize(rows, c.cols());
      tall_product(m.middleRows(first, rows).middleCols(first_col, c.rows()), c, product, false);
      m.middleRows(first, rows).middleCols(first_col, c.cols()) = product + add.middleRows(first, rows);
    }
  }
}

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

// How far from orthonormal [X W P] may be for the Rayleigh-Ritz that assumes it: Ritz values
// and residuals move by about this times |C|. 1e-13 is a thousandth of the default tolerance
// (1e-10 relative to the spectrum's bound, SpectrumOptions::tolerance); near the smallest
// tolerances allowed (1e-14) the rounding of the residuals themselves is of this size.
constexpr double kOrthonormal = 1e-13;

// W made orthogonal to X and P (both orthonormal, P possibly empty) and orthonormal itself:
// W -= X X^T W, W -= P P^T W, W <- W orthonormal_coordinates(W^T W), then again unless the first
// pass already left X^T W, P^T W and W^T W - I below kOrthonormal. One pass leaves rounding of
// the size of what it removed, so a second is needed when W was mostly in span[X P]; the check
// costs half a pass, and the first pass was enough in 23 of the 28 iterations of JHU 1 mm
// label 1 (1e-15 against X and P, up to 1.4e-13 from I; docs/benchmarks.md). Directions W only
// repeats are dropped.
void orthonormalize_against(const ConstBlock& x, const ConstBlock& p, Eigen::MatrixXd& w) {
  Eigen::MatrixXd x_part = gram(x, w), p_part = p.cols() > 0 ? gram(p, w) : Eigen::MatrixXd();
  for (int pass = 0; pass < 2 && w.cols() > 0; ++pass) {
    subtract_combination(x, x_part, w);
    if (p.cols() > 0) subtract_combination(p, p_part, w);
    const Eigen::MatrixXd map = orthonormal_coordinates(gram(w, w));
    Eigen::MatrixXd orthonormal;
    combine(w, map, orthonormal);
    w = std::move(orthonormal);
    if (pass == 1 || w.cols() == 0) break;
    x_part = gram(x, w);
    if (p.cols() > 0) p_part = gram(p, w);
    const Eigen::MatrixXd self = gram(w, w) - Eigen::MatrixXd::Identity(w.cols(), w.cols());
    auto small = [](const Eigen::MatrixXd& m) { return m.size() == 0 || m.cwiseAbs().maxCoeff() <= kOrthonormal; };
    if (small(x_part) && small(p_part) && small(self)) break;
  }
}

// The coordinates in S = [X W P] (orthonormal) of the next P: the W, P parts of the new X's
// columns `active` (rows bx.. of x_coordinates), made orthogonal to the new X in coordinates and
// orthonormal (Householder QR of [x_coordinates | those parts], where the small matrices cost
// nothing). P = S Q and C P = (C S) Q then agree to rounding, the next basis is orthonormal,
// and span[X_new, P] = span[X_new, X] on those columns, as in Knyazev's P. A column is dropped
// when its part is rounding (below 1e-14: X did not move) or when what is left of it after X_new
// and the columns before is below 1e-8 of it (a direction already there). The test is relative:
// near convergence the parts are 1e-9 to 1e-5, and an absolute 1e-10 dropped all but one or two
// of 75 columns, leaving a steepest descent (Harvard-Oxford 1 mm label 29: 225 iterations, 77
// with the relative test).
Eigen::MatrixXd next_p_coordinates(const Eigen::MatrixXd& x_coordinates, Eigen::Index bx, const std::vector<Eigen::Index>& active) {
  const Eigen::Index cols = x_coordinates.rows(), keep = x_coordinates.cols();
  std::vector<Eigen::Index> moving;
  for (const Eigen::Index c : active)
    if (c < keep) moving.push_back(c);
  Eigen::MatrixXd stacked(cols, keep + static_cast<Eigen::Index>(moving.size()));
  stacked.leftCols(keep) = x_coordinates;
  for (std::size_t k = 0; k < moving.size(); ++k) {
    auto z = stacked.col(keep + static_cast<Eigen::Index>(k));
    z = x_coordinates.col(moving[k]);
    z.head(bx).setZero();
  }
  if (stacked.cols() > cols) stacked.conservativeResize(cols, cols);  // no more directions than S has
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(stacked);
  const Eigen::MatrixXd q = qr.householderQ() * Eigen::MatrixXd::Identity(cols, stacked.cols());
  std::vector<Eigen::Index> kept;
  for (Eigen::Index j = keep; j < stacked.cols(); ++j) {
    const double part = stacked.col(j).norm();
    if (part > 1e-14 && std::abs(qr.matrixQR()(j, j)) > 1e-8 * part) kept.push_back(j);
  }
  Eigen::MatrixXd out(cols, static_cast<Eigen::Index>(kept.size()));
  for (std::size_t k = 0; k < kept.size(); ++k) out.col(static_cast<Eigen::Index>(k)) = q.col(kept[k]);
  return out;
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

// The same on an orthonormal S (S^T S = I to rounding): the eigenproblem of S^T C S alone.
RitzPairs rayleigh_ritz_orthonormal(Eigen::MatrixXd projected, Eigen::Index keep) {
  projected = 0.5 * (projected + projected.transpose()).eval();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(projected);
  keep = std::min<Eigen::Index>(keep, projected.rows());
  return {eig.eigenvalues().head(keep), eig.eigenvectors().leftCols(keep)};
}

// Whether every column of S has unit norm within 1e-10: the cheap check (N x cols) that the
// basis LOBPCG built orthonormal still is. Its columns are orthogonal by construction (W
// against X and P, P against X in coordinates, X and P from orthonormal coordinates); what
// rounding could make drift over many iterations is caught here first, and then S^T S is formed.
bool unit_columns(const ConstBlock& s) {
  for (Eigen::Index c = 0; c < s.cols(); ++c)
    if (std::abs(s.col(c).squaredNorm() - 1) > 1e-10) return false;
  return true;
}

}  // namespace

Eigen::MatrixXd lobpcg_start(Eigen::Index n, Eigen::Index b) {
  Eigen::MatrixXd start(n, b);
  std::uint64_t state = 0x9e3779b97f4a7c15ULL;
  for (Eigen::Index k = 0; k < start.size(); ++k) {
    state = state * 6364136223846793005ULL + 1442695040888963407ULL;
    start.data()[k] = static_cast<double>(state >> 11) * 0x1.0p-53 - 0.5;
  }
  return start;
}

LobpcgResult lobpcg(const BlockMap& apply_c, const BlockMap& apply_t, Eigen::MatrixXd start, int count,
                    double tolerance, int max_iterations, const std::function<void(int, double)>& progress) {
  LobpcgResult result;
  const Eigen::Index n = start.rows(), b = start.cols();
  // Every N-row block is allocated once, here: at large N a fresh block per iteration cost
  // more in first-touch page faults than the arithmetic (N = 7e5: about 250 MB each).
  // The basis lives in s and its image in cs as [Q | X | W | P]: Q the locked columns (below),
  // X the active Ritz vectors, W and P this iteration's other directions. Once copied there, P
  // and C P are free for the next P and C P, and the next X and C X are formed in place
  // (11 blocks of N x b in all).
  Eigen::MatrixXd s(n, 3 * b), cs(n, 3 * b), r(n, b), w(n, b), cw(n, b), p(n, b), cp(n, b);
  for (Eigen::MatrixXd* m : {&s, &cs, &r, &w, &cw, &p, &cp})
    advise_huge_pages(m->data(), sizeof(double) * static_cast<std::size_t>(m->size()));
  apply_c(start, cw);
  result.products += static_cast<int>(b);
  RitzPairs ritz = rayleigh_ritz(gram(start, start), gram(start, cw), b);
  Eigen::Index bx = ritz.values.size();
  combine(start, ritz.coordinates, w);
  combine(cw, ritz.coordinates, p);
  s.leftCols(bx) = w;
  cs.leftCols(bx) = p;
  p.resize(n, 0);  // no P in the first iteration
  cp.resize(n, 0);
  start.resize(0, 0);
  Eigen::VectorXd lambda = ritz.values;
  // Hard locking: the leading wanted Ritz pairs whose residuals met the tolerance leave the
  // iteration for good (Q, `locked` columns, their values and residuals kept). W stays
  // orthogonal to them, as to X, but the Rayleigh-Ritz step and the block combinations no
  // longer carry them: on a label of 50 eigenpairs these were most of an iteration's dense work
  // once half the columns had converged (docs/benchmarks.md). Only a leading run is locked, so
  // that Q holds the smallest Ritz values and the active ones come after them.
  Eigen::Index locked = 0;
  Eigen::VectorXd locked_values(count), locked_residuals(count), residual_norms;
  for (int iteration = 0;; ++iteration) {
    const Eigen::Index wanted = std::max<Eigen::Index>(count - locked, 0);
    {
      const auto x = s.middleCols(locked, bx), cx = cs.middleCols(locked, bx);
      r.resize(n, bx);  // no-op unless Rayleigh-Ritz dropped directions
      r.noalias() = cx - x * lambda.asDiagonal();
    }
    residual_norms = r.colwise().norm().transpose();
    result.iterations = iteration;
    const double worst_active = wanted > 0 ? residual_norms.head(std::min(wanted, bx)).maxCoeff() : 0.0;
    const double worst_locked = locked > 0 ? locked_residuals.head(locked).maxCoeff() : 0.0;
    if (progress) progress(iteration, std::max(worst_active, worst_locked) / tolerance);
    if (bx >= wanted && (residual_norms.head(wanted).array() <= tolerance).all()) {
      result.converged = true;
      break;
    }
    if (iteration == max_iterations) break;
    Eigen::Index lock = 0;
    while (lock < wanted && lock < bx && residual_norms[lock] <= tolerance) ++lock;
    if (lock > 0) {
      locked_values.segment(locked, lock) = lambda.head(lock);
      locked_residuals.segment(locked, lock) = residual_norms.head(lock);
      locked += lock, bx -= lock;
      lambda = lambda.tail(bx).eval();
    }
    // Soft locking: the active columns whose residual is already below the tolerance add no
    // direction to W (their residuals are rounding noise) nor to the next P.
    std::vector<Eigen::Index> active;
    for (Eigen::Index c = 0; c < bx; ++c)
      if (residual_norms[lock + c] > tolerance) active.push_back(c);
    if (lock > 0 || static_cast<Eigen::Index>(active.size()) < bx) {
      Eigen::MatrixXd kept(n, static_cast<Eigen::Index>(active.size()));
      for (std::size_t c = 0; c < active.size(); ++c) kept.col(static_cast<Eigen::Index>(c)) = r.col(lock + active[c]);
      r = std::move(kept);
    }
    // Preconditioned residuals, made orthogonal to Q, X and P and orthonormal, then multiplied
    // by C: the basis [X W P] is orthonormal and orthogonal to Q. Rayleigh-Ritz on a merely
    // independent basis (its Gram matrix inverted) lost 1e-12 directions on real labels as X
    // converged, and the iteration stalled at 100 times the tolerance (issue 23).
    apply_t(r, w);
    orthonormalize_against(s.leftCols(locked + bx), p, w);
    apply_c(w, cw);
    result.products += static_cast<int>(w.cols());
    // Rayleigh-Ritz on [X, W, P], orthonormal: S^T C S alone (S^T S, its eigen-decomposition
    // and the map from it were a third of the time on small labels, where the dense algebra
    // outweighs the products). Should the columns' norms have drifted, S^T S is formed.
    const Eigen::Index bw = w.cols(), bp = p.cols(), cols = bx + bw + bp;
    s.middleCols(locked + bx, bw) = w;
    cs.middleCols(locked + bx, bw) = cw;
    s.middleCols(locked + bx + bw, bp) = p;
    cs.middleCols(locked + bx + bw, bp) = cp;
    const auto basis = s.middleCols(locked, cols), image = cs.middleCols(locked, cols);
    const std::vector<Eigen::Index> ends{bx, bx + bw, cols};
    if (unit_columns(basis)) ritz = rayleigh_ritz_orthonormal(symmetric_gram(basis, image, ends), b - locked);
    else ritz = rayleigh_ritz(symmetric_gram(basis, basis, ends), symmetric_gram(basis, image, ends), b - locked);
    const Eigen::Index keep = ritz.values.size(), tail = cols - bx;
    // The next P and C P from the same coordinates (they agree to rounding), then the new X
    // and C X as X c_x + (their W, P part), in place.
    const Eigen::MatrixXd p_coordinates = next_p_coordinates(ritz.coordinates, bx, active);
    combine(basis, p_coordinates, p);
    combine(image, p_coordinates, cp);
    combine(basis.rightCols(tail), ritz.coordinates.bottomRows(tail), r);
    combine(image.rightCols(tail), ritz.coordinates.bottomRows(tail), cw);
    const Eigen::MatrixXd x_coordinates = ritz.coordinates.topRows(bx);
    combine_in_place(s, locked, x_coordinates, r);
    combine_in_place(cs, locked, x_coordinates, cw);
    bx = keep;
    lambda = ritz.values;
  }
  const Eigen::Index found = std::min<Eigen::Index>(count, locked + bx);
  result.values.resize(found);
  result.values.head(locked) = locked_values.head(locked);
  result.values.tail(found - locked) = lambda.head(found - locked);
  result.vectors = s.leftCols(found);
  result.residual_norms.resize(found);
  result.residual_norms.head(locked) = locked_residuals.head(locked);
  result.residual_norms.tail(found - locked) = residual_norms.head(found - locked);
  return result;
}

}  // namespace digilap::detail
