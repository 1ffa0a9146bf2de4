// The eigen-solver's own dense kernels (lib/core/tall_products.hpp, lib/core/block_ldlt.hpp),
// against Eigen's products and Eigen's sparse LDL^T solve: every tile edge (blocks of 1 to 37
// columns, row counts that are not multiples of 8 or 16), blocks inside larger matrices (outer
// strides), and the solves bit for bit the same on 1 and 2 threads; and the resize of the blocks
// on huge pages.
#include "core/block_ldlt.hpp"
#include "core/huge_pages.hpp"
#include "core/tall_products.hpp"

#include "on_threads.hpp"

#include <gtest/gtest.h>

#include <Eigen/SparseCholesky>

#include <cstring>
#include <vector>

using namespace digilap::detail;

namespace {
Eigen::MatrixXd random_block(Eigen::Index rows, Eigen::Index cols, unsigned seed) {
  std::srand(seed);
  return Eigen::MatrixXd::Random(rows, cols);
}

// A sum of n terms of size |x| |y| each is off by at most n eps |x| |y| in any order; with 1e-13
// relative to that scale the bound holds for n up to about 400 rows a lane (here 2,049 rows
// over 8 lanes, 256 a lane) and still fails for an element off by one term.
double scaled_error(const Eigen::MatrixXd& got, const Eigen::MatrixXd& expected, double scale) {
  return (got - expected).cwiseAbs().maxCoeff() / scale;
}
}  // namespace

TEST(TallProducts, GramEqualsEigensOnEveryTileEdge) {
  for (Eigen::Index rows : {1, 7, 8, 255, 257, 2049})
    for (Eigen::Index p : {1, 3, 4, 5, 30})
      for (Eigen::Index q : {1, 2, 4, 7, 37}) {
        const Eigen::MatrixXd big_x = random_block(rows + 3, p + 2, 1), big_y = random_block(rows + 3, q + 1, 2);
        const auto x = big_x.block(2, 1, rows, p);  // outer stride > rows
        const auto y = big_y.block(1, 0, rows, q);
        Eigen::MatrixXd out = Eigen::MatrixXd::Constant(p + 4, q + 4, 7.0);  // a block of it, the rest untouched
        tall_gram(x, y, out.block(2, 3, p, q));
        const Eigen::MatrixXd expected = x.transpose() * y;
        EXPECT_LE(scaled_error(out.block(2, 3, p, q), expected, static_cast<double>(rows)), 1e-13) << rows << " " << p << " " << q;
        EXPECT_EQ((out.topRows(2).array() != 7.0).count(), 0);
        EXPECT_EQ((out.leftCols(3).array() != 7.0).count(), 0);
      }
}

TEST(TallProducts, ProductAndSubtractionEqualEigensOnEveryTileEdge) {
  for (Eigen::Index rows : {1, 7, 8, 15, 16, 17, 33, 2048})
    for (Eigen::Index p : {1, 5, 30})
      for (Eigen::Index q : {1, 3, 8, 9, 17, 31}) {
        const Eigen::MatrixXd big_x = random_block(rows + 5, p + 1, 3), c = random_block(p, q, 4);
        const auto x = big_x.block(3, 1, rows, p);
        Eigen::MatrixXd out = Eigen::MatrixXd::Constant(rows + 2, q, 7.0);
        tall_product(x, c, out.middleRows(1, rows), false);
        const Eigen::MatrixXd expected = x * c;
        EXPECT_LE(scaled_error(out.middleRows(1, rows), expected, static_cast<double>(p)), 1e-14) << rows << " " << p << " " << q;
        EXPECT_EQ((out.row(0).array() != 7.0).count() + (out.row(rows + 1).array() != 7.0).count(), 0);
        const Eigen::MatrixXd start = random_block(rows, q, 5);
        Eigen::MatrixXd z = start;
        tall_product(x, c, z, true);
        EXPECT_LE(scaled_error(z, start - expected, static_cast<double>(p) + 1), 1e-14) << rows << " " << p << " " << q;
      }
}

namespace {
// A 2-D grid Laplacian plus a small multiple of the identity (positive definite), lower triangle.
Eigen::SparseMatrix<double> grid_matrix(int side) {
  const int n = side * side;
  std::vector<Eigen::Triplet<double>> entries;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j) {
      const int k = i * side + j;
      entries.emplace_back(k, k, 4.01);
      if (i + 1 < side) entries.emplace_back(k + side, k, -1.0);
      if (j + 1 < side) entries.emplace_back(k + 1, k, -1.0);
    }
  Eigen::SparseMatrix<double> lower(n, n);
  lower.setFromTriplets(entries.begin(), entries.end());
  return lower;
}
}  // namespace

TEST(BlockLdlt, SolvesEqualEigensAndDoNotDependOnThreads) {
  const Eigen::SparseMatrix<double> lower = grid_matrix(60);
  BlockLdlt solver;
  ASSERT_TRUE(solver.compute(lower));
  const Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> reference(lower);
  for (Eigen::Index b : {1, 7, 8, 9, 30}) {
    const Eigen::MatrixXd x = random_block(lower.rows(), b, 6);
    const Eigen::MatrixXd one = on_threads(1, [&] {
      Eigen::MatrixXd y = x;
      solver.solve_in_place(y);
      return y;
    });
    const Eigen::MatrixXd two = on_threads(2, [&] {
      Eigen::MatrixXd y = x;
      solver.solve_in_place(y);
      return y;
    });
    // In place on a view, as LOBPCG calls it (columns of a wider block): the same bits, and the
    // columns beside it untouched.
    Eigen::MatrixXd wide = Eigen::MatrixXd::Constant(lower.rows(), b + 2, 7.0);
    wide.middleCols(1, b) = x;
    solver.solve_in_place(wide.middleCols(1, b));
    EXPECT_EQ(std::memcmp(one.data(), wide.middleCols(1, b).eval().data(), sizeof(double) * static_cast<std::size_t>(one.size())), 0) << b;
    EXPECT_TRUE((wide.col(0).array() == 7.0).all() && (wide.col(b + 1).array() == 7.0).all()) << b;
    const Eigen::MatrixXd expected = reference.solve(x);
    // The same factor and the same operations up to the order of a row's updates and 1 / d
    // against a division: 1e-12 of the solution (the matrix's condition number is about 400).
    EXPECT_LE((one - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff()) << b;
    ASSERT_EQ(one.size(), two.size());
    EXPECT_EQ(std::memcmp(one.data(), two.data(), sizeof(double) * static_cast<std::size_t>(one.size())), 0) << b;
  }
}

TEST(BlockLdlt, RefusesAnIndefiniteMatrix) {
  Eigen::SparseMatrix<double> lower = grid_matrix(5);
  lower.coeffRef(3, 3) = -10;
  BlockLdlt solver;
  EXPECT_FALSE(solver.compute(lower));
}

// resize_on_huge_pages (core/huge_pages.hpp): the shape asked for; the same buffer when only the
// shape changes (no free, no fresh page faults: why products use it); a fresh, usable one when
// the number of values changes, large enough to be advised.
TEST(HugePages, ResizeGivesTheShapeAndKeepsTheBufferForTheSameSize) {
  Eigen::MatrixXd m = Eigen::MatrixXd::Constant(1000, 8, 2.0);
  const double* before = m.data();
  digilap::detail::resize_on_huge_pages(m, 8, 1000);
  EXPECT_EQ(m.rows(), 8);
  EXPECT_EQ(m.cols(), 1000);
  EXPECT_EQ(m.data(), before);
  digilap::detail::resize_on_huge_pages(m, 600000, 8);  // 38 MB: advised
  ASSERT_EQ(m.rows(), 600000);
  ASSERT_EQ(m.cols(), 8);
  m.setConstant(0.5);
  EXPECT_EQ(m.sum(), 0.5 * 600000 * 8);
  digilap::detail::resize_on_huge_pages(m, 0, 8);
  EXPECT_EQ(m.size(), 0);
}

