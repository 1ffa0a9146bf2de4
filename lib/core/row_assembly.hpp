// Internal: the rows of a heat-kernel Laplacian in compressed storage, whatever the dimension
// (contours in 2D, surfels in 3D): allocation once from the row sizes, then each row turned from
// squared distances into L and A = M L, rows summing to zero.
#pragma once

#include "digilap/core/operator.hpp"
#include "gaussian_kernel.hpp"
#include "huge_pages.hpp"

#include <algorithm>
#include <numeric>
#include <vector>

namespace digilap::detail {

// Allocates L and A with the given row sizes (off-diagonal counts + 1 for the diagonal).
inline void allocate(SparseMatrix& m, Eigen::Index n, const std::vector<Eigen::Index>& row_nnz) {
  m.resize(n, n);
  m.resizeNonZeros(static_cast<Eigen::Index>(std::accumulate(row_nnz.begin(), row_nnz.end(), Eigen::Index(0))));
  // Not yet written: the rows fill them in parallel, first touch on huge pages.
  advise_huge_pages(m.valuePtr(), sizeof(double) * static_cast<std::size_t>(m.nonZeros()));
  advise_huge_pages(m.innerIndexPtr(), sizeof(int) * static_cast<std::size_t>(m.nonZeros()));
  int* outer = m.outerIndexPtr();
  outer[0] = 0;
  for (Eigen::Index r = 0; r < n; ++r) outer[r + 1] = outer[r] + static_cast<int>(row_nnz[r]);
}

// Row r of L and A, whose columns (ascending) are already in L's index slots and whose squared
// distances are in L's value slots (0 on the diagonal, at position `diag`). Turns them into
// L_rj = w(d) mu_j and A_rj = w(d) (mu_r mu_j) (the product mu_r mu_j is commutative, so A is
// symmetric bit for bit), then sets the diagonals so that every row sums to zero. A may be null
// (L only). With weights' measures mu_i = m_i c_i that differ from the masses m_i (the surfaces'
// intrinsic kernel), row_scale = c_r keeps L = M^(-1) A: L_rj = w mu_j c_r (exact for c_r = 1).
inline void finish_row(SparseMatrix& L, SparseMatrix* A, Eigen::Index r, Eigen::Index diag, const Eigen::VectorXd& mu,
                       double inv_4t, double scale, double row_scale = 1.0) {
  const int begin = L.outerIndexPtr()[r], count = L.outerIndexPtr()[r + 1] - begin;
  const int* col = L.innerIndexPtr() + begin;
  double* lval = L.valuePtr() + begin;
  gaussian_weights(lval, count, inv_4t, scale);  // squared distances -> kernel weights
  const double mu_r = mu[r];
  double lsum = 0, asum = 0;
  if (!A) {  // L only
    for (int k = 0; k < count; ++k) {
      if (k == diag) continue;
      lval[k] *= mu[col[k]] * row_scale;
      lsum += lval[k];
    }
    lval[diag] = -lsum;
    return;
  }
  double* aval = A->valuePtr() + begin;
  std::copy(col, col + count, A->innerIndexPtr() + begin);
  for (int k = 0; k < count; ++k) {
    if (k == diag) continue;
    const double w = lval[k], mu_j = mu[col[k]];
    lval[k] = w * mu_j * row_scale;
    aval[k] = w * (mu_r * mu_j);
    lsum += lval[k];
    asum += aval[k];
  }
  lval[diag] = -lsum;
  aval[diag] = -asum;
}

}  // namespace digilap::detail
