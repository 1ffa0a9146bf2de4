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
using Block = Eigen::Ref<Eigen::MatrixXd>;

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

// Each column's squared norm, by chunks of rows added in chunk order.
Eigen::VectorXd column_squared_norms(const ConstBlock& x) {
  return sum_over_chunks(x.rows(), x.cols(), 1, [&](Eigen::Index first, Eigen::Index rows, Eigen::MatrixXd& out) {
    out.col(0) = x.middleRows(first, rows).colwise().squaredNorm().transpose();
  });
}

// r = C X - X Lambda, over the threads by chunks of rows (element by element: the same bits
// whatever the thread; serial, this and the norms were a few percent of a surface spectrum's time).
void residuals(const ConstBlock& cx, const ConstBlock& x, const Eigen::VectorXd& lambda, Block r) {
  const Eigen::Index chunks = chunk_count(x.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index k = 0; k < chunks; ++k) {
    const Eigen::Index first = k * kChunkRows, rows = std::min(kChunkRows, x.rows() - first);
    r.middleRows(first, rows).noalias() = cx.middleRows(first, rows) - x.middleRows(first, rows) * lambda.asDiagonal();
  }
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

// out = x c (out: x.rows() x c.cols(); not aliased with x)
void combine(const ConstBlock& x, const Eigen::MatrixXd& c, Block out) {
  const Eigen::Index chunks = chunk_count(x.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index k = 0; k < chunks; ++k) {
    const Eigen::Index first = k * kChunkRows, rows = std::min(kChunkRows, x.rows() - first);
    tall_product(x.middleRows(first, rows), c, out.middleRows(first, rows), false);
  }
}

// out -= x c (not aliased with x)
void subtract_combination(const ConstBlock& x, const Eigen::MatrixXd& c, Block out) {
  const Eigen::Index chunks = chunk_count(x.rows());
#pragma omp parallel for schedule(static)
  for (Eigen::Index k = 0; k < chunks; ++k) {
    const Eigen::Index first = k * kChunkRows, rows = std::min(kChunkRows, x.rows() - first);
    tall_product(x.middleRows(first, rows), c, out.middleRows(first, rows), true);
  }
}

// The columns [first_col, first_col + new_cols) of m <- f(its columns [first_col, first_col +
// old_cols)), in place, a chunk of rows at a time: f(old, out, scratch) gets a copy of the
// chunk's old values, and what it writes to `out` (the chunk's new values) is copied back, so
// the two ranges may overlap. A row's new values depend on its old ones only, so no N-row
// temporary is needed (at N = 150,000 and 60 columns each is 72 MB). `scratch` is the thread's.
template <typename F>
void transform_columns(Eigen::MatrixXd& m, Eigen::Index first_col, Eigen::Index old_cols, Eigen::Index new_cols, const F& f) {
  const Eigen::Index chunks = chunk_count(m.rows());
#pragma omp parallel
  {
    Eigen::MatrixXd old, out, scratch;  // one chunk's, reused by the thread
#pragma omp for schedule(static)
    for (Eigen::Index k = 0; k < chunks; ++k) {
      const Eigen::Index first = k * kChunkRows, rows = std::min(kChunkRows, m.rows() - first);
      old = m.block(first, first_col, rows, old_cols);
      out.resize(rows, new_cols);
      f(old, out, scratch);
      m.block(first, first_col, rows, new_cols) = out;
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

// The `width` columns of W (m's columns from `first`) made orthogonal to the basis B (orthonormal;
// Q, X and P side by side, possibly empty) and orthonormal themselves: W -= B B^T W, W <- W
// orthonormal_coordinates(W^T W), then again unless the first pass already left B^T W and
// W^T W - I below kOrthonormal. One pass leaves rounding of the size of what it removed, so a
// second is needed when W was mostly in span B; the check costs half a pass, and the first pass
// was enough in 23 of the 28 iterations of JHU 1 mm label 1 (1e-15 against X and P, up to
// 1.4e-13 from I; docs/benchmarks.md). Directions W only repeats are dropped: returns how many
// columns are left (from `first` on).
Eigen::Index orthonormalize_against(const ConstBlock& basis, Eigen::MatrixXd& m, Eigen::Index first, Eigen::Index width) {
  Eigen::MatrixXd basis_part = basis.cols() > 0 ? gram(basis, m.middleCols(first, width)) : Eigen::MatrixXd();
  for (int pass = 0; pass < 2 && width > 0; ++pass) {
    if (basis.cols() > 0) subtract_combination(basis, basis_part, m.middleCols(first, width));
    const Eigen::MatrixXd map = orthonormal_coordinates(gram(m.middleCols(first, width), m.middleCols(first, width)));
    transform_columns(m, first, width, map.cols(), [&](const Eigen::MatrixXd& old, Eigen::MatrixXd& out, Eigen::MatrixXd&) {
      tall_product(old, map, out, false);
    });
    width = map.cols();
    if (pass == 1 || width == 0) break;
    const auto w = m.middleCols(first, width);
    if (basis.cols() > 0) basis_part = gram(basis, w);
    const Eigen::MatrixXd self = gram(w, w) - Eigen::MatrixXd::Identity(width, width);
    auto small = [](const Eigen::MatrixXd& x) { return x.size() == 0 || x.cwiseAbs().maxCoeff() <= kOrthonormal; };
    if (small(basis_part) && small(self)) break;
  }
  return width;
}

// The coordinates in S = [X P W] (orthonormal) of the next P: the P, W parts of the new X's
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
  return ((column_squared_norms(s).array() - 1).abs() <= 1e-10).all();
}

}  // namespace

// Growth: where the usual guards end inside a cluster that the wanted ones also fall in (50
// eigenpairs of a sphere: l = 7 is 15 eigenvalues, from the 50th to the 64th, within 0.3% of each
// other) the ratio is 1 to 0.3%: 31 iterations on the sphere at h = 0.025 against 14 with the
// block taken past the cluster. Shrinking: a sphere's 20 eigenpairs, whose usual 30 columns end
// 5 columns into l = 5 (11 eigenvalues within 0.05% of each other), take 25 columns, the block
// ending with l = 4 (h = 0.0125: 301 -> 256 column products for one more iteration, 11 -> 12:
// the same wall time within noise, a peak 6% lower; 16 eigenpairs, no guards: 26% lower;
// docs/benchmarks.md). The first eigenvalue past the block falls by at most 2%.
Eigen::Index block_at_a_gap(const Eigen::VectorXd& estimates, int count, Eigen::Index block, Eigen::Index max_block) {
  constexpr double kClusterGap = 1.1, kSameCluster = 1.02;
  if (count < 1 || block < count || estimates.size() <= block) return block;
  const double last_wanted = estimates[count - 1];
  if (estimates[block] < kClusterGap * last_wanted) {
    Eigen::Index columns = block;
    while (columns < std::min(max_block, estimates.size()) && estimates[columns] < kClusterGap * last_wanted) ++columns;
    return columns < estimates.size() && estimates[columns] >= kClusterGap * last_wanted ? columns : block;
  }
  Eigen::Index columns = block;
  while (columns > count && kSameCluster * estimates[columns - 1] >= estimates[block]) --columns;
  return columns;
}

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
                    double tolerance, int max_iterations, const std::function<void(int, double)>& progress, bool with_guards) {
  LobpcgResult result;
  const Eigen::Index n = start.rows(), b = start.cols();
  // Every N-row block is allocated once, here: at large N a fresh block per iteration cost
  // more in first-touch page faults than the arithmetic (N = 7e5: about 250 MB each). The
  // basis lives in s and its image in cs as [Q | X | P | W]: Q the locked columns (below), X the
  // active Ritz vectors, P and W this iteration's other directions. W is written where it
  // belongs (the preconditioner and the operator write into s and cs), and the next X and P
  // replace the columns from X on, in place (transform_columns). r holds the residuals.
  Eigen::MatrixXd s, cs, r;
  auto allocate = [n](Eigen::MatrixXd& m, Eigen::Index cols) {
    m.resize(n, cols);
    advise_huge_pages(m.data(), sizeof(double) * static_cast<std::size_t>(m.size()));
  };
  allocate(r, b);
  apply_c(start, r);
  result.products += static_cast<int>(b);
  RitzPairs ritz = rayleigh_ritz(gram(start, start), gram(start, r), b);
  Eigen::Index bx = ritz.values.size(), bp = 0;  // no P in the first iteration
  allocate(s, 3 * b);
  combine(start, ritz.coordinates, s.leftCols(bx));
  start.resize(0, 0);
  allocate(cs, 3 * b);
  combine(r, ritz.coordinates, cs.leftCols(bx));
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
    residuals(cs.middleCols(locked, bx), s.middleCols(locked, bx), lambda, r.leftCols(bx));
    residual_norms = column_squared_norms(r.leftCols(bx)).cwiseSqrt();
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
    // direction to W (their residuals are rounding noise) nor to the next P. Their residuals
    // leave r, the others moving left (column lock + active[c] >= c: read before written).
    std::vector<Eigen::Index> active;
    for (Eigen::Index c = 0; c < bx; ++c)
      if (residual_norms[lock + c] > tolerance) active.push_back(c);
    const auto ba = static_cast<Eigen::Index>(active.size());
    for (Eigen::Index c = 0; c < ba; ++c)
      if (lock + active[static_cast<std::size_t>(c)] != c) r.col(c) = r.col(lock + active[static_cast<std::size_t>(c)]);
    // Preconditioned residuals, made orthogonal to Q, X and P and orthonormal, then multiplied
    // by C: the basis [X P W] is orthonormal and orthogonal to Q. Rayleigh-Ritz on a merely
    // independent basis (its Gram matrix inverted) lost 1e-12 directions on real labels as X
    // converged, and the iteration stalled at 100 times the tolerance (issue 23).
    const Eigen::Index at_w = locked + bx + bp;  // W's first column in s and cs
    apply_t(r.leftCols(ba), s.middleCols(at_w, ba));
    const Eigen::Index bw = orthonormalize_against(s.leftCols(at_w), s, at_w, ba);
    apply_c(s.middleCols(at_w, bw), cs.middleCols(at_w, bw));
    result.products += static_cast<int>(bw);
    // Rayleigh-Ritz on [X, P, W], orthonormal: S^T C S alone (S^T S, its eigen-decomposition
    // and the map from it were a third of the time on small labels, where the dense algebra
    // outweighs the products). Should the columns' norms have drifted, S^T S is formed.
    const Eigen::Index cols = bx + bp + bw;
    const std::vector<Eigen::Index> ends{bx, bx + bp, cols};
    {
      const auto basis = s.middleCols(locked, cols), image = cs.middleCols(locked, cols);
      if (unit_columns(basis)) ritz = rayleigh_ritz_orthonormal(symmetric_gram(basis, image, ends), b - locked);
      else ritz = rayleigh_ritz(symmetric_gram(basis, basis, ends), symmetric_gram(basis, image, ends), b - locked);
    }
    // The next X (X c_x plus its P, W part) and the next P, from the same coordinates (so P and
    // C P agree to rounding), over the columns from X on, in place.
    const Eigen::Index keep = ritz.values.size(), tail = cols - bx;
    const Eigen::MatrixXd p_coordinates = next_p_coordinates(ritz.coordinates, bx, active);
    const Eigen::MatrixXd x_coordinates = ritz.coordinates.topRows(bx), tail_coordinates = ritz.coordinates.bottomRows(tail);
    const Eigen::Index next_bp = p_coordinates.cols();
    auto next_x_and_p = [&](const Eigen::MatrixXd& old, Eigen::MatrixXd& out, Eigen::MatrixXd& scratch) {
      scratch.resize(old.rows(), keep);
      tall_product(old.rightCols(tail), tail_coordinates, scratch, false);
      tall_product(old.leftCols(bx), x_coordinates, out.leftCols(keep), false);
      out.leftCols(keep) += scratch;
      tall_product(old, p_coordinates, out.rightCols(next_bp), false);
    };
    transform_columns(s, locked, cols, keep + next_bp, next_x_and_p);
    transform_columns(cs, locked, cols, keep + next_bp, next_x_and_p);
    bx = keep, bp = next_bp;
    lambda = ritz.values;
  }
  const Eigen::Index found = with_guards ? locked + bx : std::min<Eigen::Index>(count, locked + bx);
  result.values.resize(found);
  result.values.head(locked) = locked_values.head(locked);
  result.values.tail(found - locked) = lambda.head(found - locked);
  r.resize(0, 0);
  cs.resize(0, 0);
  result.vectors = s.leftCols(found);
  result.residual_norms.resize(found);
  result.residual_norms.head(locked) = locked_residuals.head(locked);
  result.residual_norms.tail(found - locked) = residual_norms.head(found - locked);
  return result;
}

}  // namespace digilap::detail
