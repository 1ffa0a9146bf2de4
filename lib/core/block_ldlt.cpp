#include "block_ldlt.hpp"

#include "lanes.hpp"

#include <Eigen/SparseCholesky>

#include <algorithm>
#include <cstring>

namespace digilap::detail {

namespace {
// A row of the block is 8 doubles, one Lanes8u (a std::vector does not align them to 64).

// z <- L^(-T) D^(-1) L^(-1) z on 8 columns, z row by row (a row's 8 values one vector).
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default"))) void solve_lanes(
    const int* start, const int* row, const double* value, const double* inverse_d, Eigen::Index n, Lanes8u* z) {
  for (Eigen::Index j = 0; j < n; ++j) {
    const Lanes8u zj = z[j];
    for (int k = start[j]; k < start[j + 1]; ++k) z[row[k]] -= value[k] * zj;
  }
  for (Eigen::Index j = 0; j < n; ++j) z[j] *= inverse_d[j];
  for (Eigen::Index j = n - 1; j >= 0; --j) {
    Lanes8u zj = z[j];
    for (int k = start[j]; k < start[j + 1]; ++k) zj -= value[k] * z[row[k]];
    z[j] = zj;
  }
}
}  // namespace

bool BlockLdlt::compute(const Eigen::SparseMatrix<double>& lower) {
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> ldlt(lower);
  // Eigen's LDL^T fails only on a zero pivot; a negative one means the matrix is not positive
  // definite either.
  if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().array() > 0).all()) return false;
  const auto& l = ldlt.matrixL().nestedExpression();
  const Eigen::Index n = l.cols();
  start_.assign(static_cast<std::size_t>(n + 1), 0);
  row_.clear(), value_.clear();
  row_.reserve(static_cast<std::size_t>(l.nonZeros())), value_.reserve(static_cast<std::size_t>(l.nonZeros()));  // 1e6 at N = 36,000
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(l, j); it; ++it)
      if (it.row() > j) row_.push_back(static_cast<int>(it.row())), value_.push_back(it.value());  // L is unit lower
    start_[static_cast<std::size_t>(j + 1)] = static_cast<int>(row_.size());
  }
  inverse_d_ = ldlt.vectorD().cwiseInverse();
  const auto& p = ldlt.permutationP().indices();
  position_.resize(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) position_[static_cast<std::size_t>(i)] = p[i];
  return true;
}

void BlockLdlt::solve_in_place(Eigen::Ref<Eigen::MatrixXd> y) const {
  const Eigen::Index n = y.rows(), b = y.cols(), groups = (b + 7) / 8;
#pragma omp parallel
  {
    std::vector<double> rows(8 * static_cast<std::size_t>(n));  // this thread's
    Lanes8u* z = reinterpret_cast<Lanes8u*>(rows.data());
#pragma omp for schedule(dynamic, 1)
    for (Eigen::Index g = 0; g < groups; ++g) {
      const Eigen::Index first = 8 * g, count = std::min<Eigen::Index>(8, b - first);
      for (Eigen::Index i = 0; i < n; ++i) {
        double* v = rows.data() + 8 * static_cast<std::size_t>(position_[static_cast<std::size_t>(i)]);
        for (Eigen::Index c = 0; c < 8; ++c) v[c] = c < count ? y(i, first + c) : 0.0;
      }
      solve_lanes(start_.data(), row_.data(), value_.data(), inverse_d_.data(), n, z);
      for (Eigen::Index i = 0; i < n; ++i) {
        const double* v = rows.data() + 8 * static_cast<std::size_t>(position_[static_cast<std::size_t>(i)]);
        for (Eigen::Index c = 0; c < count; ++c) y(i, first + c) = v[c];
      }
    }
  }
}

}  // namespace digilap::detail
