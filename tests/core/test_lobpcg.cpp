// The block LOBPCG behind every matrix-free spectrum (lib/core/lobpcg.hpp), on its own: a
// problem with exact eigenpairs that needs many iterations, where rounding in a basis assumed
// orthonormal would have time to build up.
#include "core/lobpcg.hpp"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <Eigen/SparseCore>

#include <cmath>
#include <malloc.h>

namespace {

// The path graph's Laplacian (2 on the diagonal, -1 beside it, Dirichlet ends): eigenvalues
// 2 - 2 cos(k pi / (n + 1)), k = 1 .. n, the smallest clustered near 0 (k^2 pi^2 / n^2), so
// that LOBPCG without a preconditioner converges slowly.
Eigen::SparseMatrix<double> path_laplacian(int n) {
  std::vector<Eigen::Triplet<double>> entries;
  for (int i = 0; i < n; ++i) {
    entries.emplace_back(i, i, 2.0);
    if (i + 1 < n) entries.emplace_back(i, i + 1, -1.0), entries.emplace_back(i + 1, i, -1.0);
  }
  Eigen::SparseMatrix<double> c(n, n);
  c.setFromTriplets(entries.begin(), entries.end());
  return c;
}

TEST(Lobpcg, LongRunKeepsItsBasisOrthonormalAndFindsExactEigenpairs) {
  const int n = 600, count = 8, block = 12;
  const Eigen::SparseMatrix<double> c = path_laplacian(n);
  const digilap::detail::BlockMap apply_c = [&](const digilap::detail::BlockIn& in, digilap::detail::BlockOut out) { out = c * in; };
  const digilap::detail::BlockMap identity = [](const digilap::detail::BlockIn& in, digilap::detail::BlockOut out) { out = in; };
  const double tolerance = 1e-9;
  const digilap::detail::LobpcgResult r =
      digilap::detail::lobpcg(apply_c, identity, digilap::detail::lobpcg_start(n, block), count, tolerance, 5000);
  ASSERT_TRUE(r.converged);
  // The premise: a long run (the Rayleigh-Ritz step trusts S^T S = I; drift would grow with the
  // iterations).
  EXPECT_GE(r.iterations, 100);
  ASSERT_EQ(r.values.size(), count);
  for (int k = 0; k < count; ++k) {
    const double exact = 2 - 2 * std::cos((k + 1) * M_PI / (n + 1));
    // A residual below 1e-9 bounds the eigenvalue's error by 1e-9 (and by about 1e-18 / gap
    // once the vector is that close); 1e-10 leaves room above rounding (1e-15) and below any
    // error a wrong basis would cause (the gaps are 1e-4).
    EXPECT_NEAR(r.values[k], exact, 1e-10) << k;
    EXPECT_NEAR((c * r.vectors.col(k) - r.values[k] * r.vectors.col(k)).norm(), 0, tolerance) << k;
  }
  // Orthonormal vectors to 1e-12: a few hundred iterations of eps-sized rounding (2e-16 each)
  // stay two orders below; a lost orthogonality would show at 1e-8 or more.
  const Eigen::MatrixXd gram = r.vectors.transpose() * r.vectors;
  EXPECT_LE((gram - Eigen::MatrixXd::Identity(count, count)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Lobpcg, AnExactPreconditionerKeepsTheBasisOrthonormal) {
  // With T = C^(-1), T R = X - C^(-1) X Lambda is X itself up to what is left to converge: W is
  // almost all in span X, the case where one pass of orthogonalization leaves the most rounding
  // and lobpcg's check of the first pass (lobpcg.cpp, orthonormalize_against) decides whether
  // to orthogonalize again. Whatever it decides, the eigenpairs must be exact and the vectors
  // orthonormal.
  const int n = 300, count = 6, block = 10;
  const Eigen::SparseMatrix<double> c = path_laplacian(n);
  const Eigen::MatrixXd inverse = Eigen::MatrixXd(c).inverse();
  const digilap::detail::BlockMap apply_c = [&](const digilap::detail::BlockIn& in, digilap::detail::BlockOut out) { out = c * in; };
  const digilap::detail::BlockMap exact = [&](const digilap::detail::BlockIn& in, digilap::detail::BlockOut out) { out = inverse * in; };
  const double tolerance = 1e-12;
  const digilap::detail::LobpcgResult r =
      digilap::detail::lobpcg(apply_c, exact, digilap::detail::lobpcg_start(n, block), count, tolerance, 200);
  ASSERT_TRUE(r.converged);
  for (int k = 0; k < count; ++k) {
    const double exact_value = 2 - 2 * std::cos((k + 1) * M_PI / (n + 1));
    // 1e-12 is the residual's bound on the error; 1e-11 leaves room for the check's rounding.
    EXPECT_NEAR(r.values[k], exact_value, 1e-11) << k;
    EXPECT_NEAR((c * r.vectors.col(k) - r.values[k] * r.vectors.col(k)).norm(), 0, tolerance) << k;
  }
  const Eigen::MatrixXd gram = r.vectors.transpose() * r.vectors;
  EXPECT_LE((gram - Eigen::MatrixXd::Identity(count, count)).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(Lobpcg, BlockHoldsBetweenFourAndTenGuards) {
  // Guards speed up the last wanted columns, but the dense work of an iteration grows as the
  // block's square: half the count, at least 4, at most 10, never more than the rows.
  EXPECT_EQ(digilap::detail::lobpcg_block(1000, 1), 5);
  EXPECT_EQ(digilap::detail::lobpcg_block(1000, 20), 30);
  EXPECT_EQ(digilap::detail::lobpcg_block(1000, 50), 60);
  EXPECT_EQ(digilap::detail::lobpcg_block(55, 50), 55);
}

// A sphere's spectrum as a coarse problem estimates it: l (l + 1), 2 l + 1 times, each cluster
// split by 1e-4 (the digital sphere splits them by 5e-4 at most, and its clusters are 1.5
// (l = 4 to 5) to 3 (l = 1 to 2) apart), `size` of them.
Eigen::VectorXd sphere_estimates(Eigen::Index size) {
  Eigen::VectorXd values(size);
  Eigen::Index k = 0;
  for (int l = 0; k < size; ++l)
    for (int m = 0; m <= 2 * l && k < size; ++m) values[k++] = l * (l + 1) * (1 + 1e-4 * m / (2 * l + 1));
  return values;
}

TEST(Lobpcg, BlockEndsAtAGap) {
  using digilap::detail::block_at_a_gap;
  const Eigen::VectorXd sphere = sphere_estimates(100);
  // 20 eigenpairs: the usual 30 columns end 5 into l = 5 (indices 25 ... 35); its 5 columns
  // there would leave the first eigenvalue past the block at l = 5's: the block ends with l = 4.
  EXPECT_EQ(block_at_a_gap(sphere, 20, 30, 60), 25);
  // 16 (l = 0 ... 3): the usual 24 end with l = 4, all of its 9 past the wanted ones: no guards.
  EXPECT_EQ(block_at_a_gap(sphere, 16, 24, 48), 16);
  // 50: the 50th opens l = 7 (indices 49 ... 63), which the usual 60 would cut: the block takes
  // all of it, when the limit allows, else stays.
  EXPECT_EQ(block_at_a_gap(sphere, 50, 60, 120), 64);
  EXPECT_EQ(block_at_a_gap(sphere, 50, 60, 63), 60);
  // A block that ends at a gap stays: 16 wanted in a block of 25 (l = 0 ... 4).
  EXPECT_EQ(block_at_a_gap(sphere, 16, 25, 50), 25);
  // Estimates that do not reach past the block: it stays.
  EXPECT_EQ(block_at_a_gap(sphere.head(30), 20, 30, 60), 30);
  // A spectrum without clusters, each 1.2% above the one before (the 31st 14% above the 20th:
  // no growth): the block loses only the column within 2% of the first eigenvalue past it,
  // which then falls by at most 2%.
  Eigen::VectorXd even(80);
  for (Eigen::Index k = 0; k < even.size(); ++k) even[k] = std::exp(0.012 * static_cast<double>(k));
  const Eigen::Index b = block_at_a_gap(even, 20, 30, 60);
  EXPECT_EQ(b, 29);
  EXPECT_GE(1.02 * even[b], even[30]);
  // Where the first past the usual block is within 10% of the last wanted one (1% apart), the
  // block grows to the first 10% above it instead (1.31 against 1.1 x 1.19: 31 columns).
  for (Eigen::Index k = 0; k < even.size(); ++k) even[k] = 1 + 0.01 * static_cast<double>(k);
  EXPECT_EQ(block_at_a_gap(even, 20, 30, 60), 31);
  // Steps above 2% (k + 1: the 31st is 3.3% above the 30th): the block stays.
  for (Eigen::Index k = 0; k < even.size(); ++k) even[k] = 1 + static_cast<double>(k);
  EXPECT_EQ(block_at_a_gap(even, 20, 30, 60), 30);
}

}  // namespace

// Bytes the allocator hands out now (the heap's and the mmapped chunks').
double allocated_bytes() {
  const struct mallinfo2 m = mallinfo2();
  return static_cast<double>(m.uordblks) + static_cast<double>(m.hblkhd);
}

TEST(Lobpcg, HoldsNoMoreThanItsEstimate) {
  // lobpcg_bytes is what the memory checks of every caller count on (8 blocks of N x b: the
  // basis and its image, the residuals, the start or the result). The allocator's count, read
  // whenever the solver hands a block to the operator or the preconditioner, must stay within
  // it, the start included; the 12 N x b that the solver held before 2026-12-07 would not.
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "the sanitizer's allocator is not glibc's: mallinfo2 does not see the blocks";
#endif
  const int n = 20000, count = 8, block = 12;
  const Eigen::SparseMatrix<double> c = path_laplacian(n);
  const double before = allocated_bytes();
  Eigen::MatrixXd start = digilap::detail::lobpcg_start(n, block);
  double peak = 0;
  const digilap::detail::BlockMap apply_c = [&](const digilap::detail::BlockIn& in, digilap::detail::BlockOut out) {
    peak = std::max(peak, allocated_bytes() - before);
    out.noalias() = c * in;
  };
  const digilap::detail::BlockMap identity = [&](const digilap::detail::BlockIn& in, digilap::detail::BlockOut out) {
    peak = std::max(peak, allocated_bytes() - before);
    out = in;
  };
  const digilap::detail::LobpcgResult r = digilap::detail::lobpcg(apply_c, identity, std::move(start), count, 1e-9, 20);
  EXPECT_EQ(r.iterations, 20);  // every iteration's blocks were seen
  const double block_bytes = sizeof(double) * static_cast<double>(n) * block;
  EXPECT_LE(peak, digilap::detail::lobpcg_bytes(n, block)) << peak / block_bytes << " blocks";
  // The measure sees the blocks: the basis and its image alone are 6 of them.
  EXPECT_GE(peak, 6 * block_bytes) << peak / block_bytes << " blocks";
}
