// The bias-corrected pointwise estimate L_c g = L g - (t/2) L (I + t L) L g: the algebra on an
// operator of two parts with their own t, its structure (rows sum to 0, M-self-adjoint), the
// refusals, and the accuracy it buys against SPEC §5's exact Laplacian on the circle.
#include "digilap/core/bias_correction.hpp"
#include "digilap/core/error.hpp"
#include "digilap/curve/ground_truth.hpp"
#include "digilap/curve/heat_laplacian.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

using namespace digilap;

namespace {

// A heat operator of two parts built by hand: points on a line, Gaussian weights w_ij, masses
// mu_j, L_ij = w_ij mu_j, rows summing to 0 (SPEC §4's structure), part p with heat time t_p.
HeatOperator two_part_operator() {
  HeatOperator op;
  const std::vector<Eigen::Index> sizes{7, 5};
  const std::vector<double> times{0.02, 0.05};
  const Eigen::Index n = 12;
  op.mass.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) op.mass[i] = 0.1 + 0.02 * static_cast<double>(i % 4);
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, n);
  op.row_offset = {0};
  for (std::size_t p = 0, first = 0; p < sizes.size(); first += static_cast<std::size_t>(sizes[p]), ++p) {
    const auto f = static_cast<Eigen::Index>(first);
    for (Eigen::Index i = f; i < f + sizes[p]; ++i) {
      for (Eigen::Index j = f; j < f + sizes[p]; ++j) {
        if (i == j) continue;
        const double d = 0.1 * static_cast<double>(i - j);
        dense(i, j) = std::exp(-d * d / (4 * times[p])) / times[p] * op.mass[j];
      }
      dense(i, i) = -dense.row(i).sum();
    }
    op.row_offset.push_back(f + sizes[p]);
  }
  op.L = dense.sparseView();
  op.part_t = times;
  op.t = times[0];
  return op;
}

TEST(BiasCorrection, EachPartIsCorrectedWithItsOwnHeatTime) {
  const HeatOperator op = two_part_operator();
  const Eigen::MatrixXd g = Eigen::MatrixXd::Random(op.rows(), 3);
  const Eigen::MatrixXd corrected = bias_corrected_laplacian(op, g);
  // The formula evaluated block by block with dense matrices.
  const Eigen::MatrixXd dense = Eigen::MatrixXd(op.L);
  for (std::size_t p = 0; p < op.parts(); ++p) {
    const Eigen::Index first = op.row_offset[p], rows = op.row_offset[p + 1] - first;
    const Eigen::MatrixXd l = dense.block(first, first, rows, rows);
    const double t = op.part_t[p];
    const Eigen::MatrixXd expected =
        (l - 0.5 * t * l * (Eigen::MatrixXd::Identity(rows, rows) + t * l) * l) * g.middleRows(first, rows);
    // Rounding only: the same sums in another order, relative to the entries' size.
    EXPECT_LE((corrected.middleRows(first, rows) - expected).cwiseAbs().maxCoeff(), 1e-12 * expected.cwiseAbs().maxCoeff());
  }
}

TEST(BiasCorrection, RowsSumToZeroAndTheEstimateIsSelfAdjointForTheMass) {
  const HeatOperator op = two_part_operator();
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(op.rows());
  const double scale = Eigen::MatrixXd(op.L).cwiseAbs().maxCoeff();
  EXPECT_LE(bias_corrected_laplacian(op, ones).cwiseAbs().maxCoeff(), 1e-12 * scale);
  // <f, L_c g>_M = <L_c f, g>_M: a polynomial in L, which is self-adjoint for M (A = M L symmetric).
  const Eigen::VectorXd f = Eigen::VectorXd::LinSpaced(op.rows(), -1, 2).array().sin();
  const Eigen::VectorXd g = Eigen::VectorXd::LinSpaced(op.rows(), 0, 3).array().cos();
  const double fg = f.dot(op.mass.asDiagonal() * bias_corrected_laplacian(op, g).col(0));
  const double gf = g.dot(op.mass.asDiagonal() * bias_corrected_laplacian(op, f).col(0));
  EXPECT_NEAR(fg, gf, 1e-12 * scale);
}

TEST(BiasCorrection, BadInputIsRefused) {
  const HeatOperator op = two_part_operator();
  EXPECT_THROW(bias_corrected_laplacian(op, Eigen::MatrixXd::Ones(op.rows() + 1, 1)), Error);
  auto identity = [](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { y = x; };
  const Eigen::MatrixXd g = Eigen::MatrixXd::Ones(3, 1);
  EXPECT_THROW(bias_corrected_laplacian(identity, Eigen::VectorXd::Constant(2, 0.1), g), Error);
  EXPECT_THROW(bias_corrected_laplacian(identity, Eigen::Vector3d(0.1, -0.1, 0.1), g), Error);
  EXPECT_THROW(bias_corrected_laplacian(identity, Eigen::Vector3d(0.1, std::numeric_limits<double>::quiet_NaN(), 0.1), g), Error);
  auto wrong_size = [](const Eigen::MatrixXd& x, Eigen::MatrixXd& y) { y = x.topRows(1); };
  EXPECT_THROW(bias_corrected_laplacian(wrong_size, Eigen::Vector3d::Constant(0.1), g), Error);
  // t = 0 (a DEC baseline): nothing to correct.
  EXPECT_EQ(bias_corrected_laplacian(identity, Eigen::Vector3d::Zero(), g), g);
  EXPECT_THROW(heat_time_of_rows({0, 3}, {0.1, 0.2}), Error);
}

// SPEC §5: along a contour of estimated length P = sum mu, the operator's eigenvalues follow
// (1 - exp(-omega^2 t)) / t for g = cos(omega s), omega = 2 pi m / P, s the arclength S_i: the
// plain estimate -L g / g is omega^2 (1 - x/2 + ...), x = omega^2 t, a bias of x/2 (0.5-2.3%
// here). L_c's is (5/6) x^2 (the series of its factor 1 + tλ/2 - t²λ²/2), plus a floor of a
// few 1e-4 that SPEC §5 measures between the eigenvalues and the formula (measured 5.6e-4 at
// x = 0.012, 1.7e-3 at x = 0.040 where (5/6) x^2 = 1.3e-3): bounded by their sum, 8e-4 for
// the floor.
// (Against the circle's exact cos(m theta), both carry the 0.3% of the estimated length
// instead: that error is the measures', not the kernel's.)
TEST(BiasCorrection, RemovesTheKernelsBiasAlongAContour) {
  Circle circle;
  const double h = 0.005;
  const DigitalSet set = digitize(circle, h);
  const ContourSet contours = track_contours(set);
  const Measures mu = measures(contours, ii_normals(set, contours));
  const ContourOperator op = heat_laplacian(contours, mu);
  ASSERT_EQ(op.rows(), static_cast<Eigen::Index>(mu.contours[0].S.size()));
  const double length = mu.contours[0].length;
  for (int m : {2, 3, 4}) {
    const double omega = 2 * 3.14159265358979323846 * m / length, x = omega * omega * op.t;
    Eigen::VectorXd g(op.rows());
    for (Eigen::Index i = 0; i < g.size(); ++i) g[i] = std::cos(omega * mu.contours[0].S[static_cast<std::size_t>(i)]);
    const Eigen::VectorXd exact = -omega * omega * g;
    const double scale = omega * omega;
    const double plain = (op.L * g - exact).cwiseAbs().maxCoeff() / scale;
    const double corrected = (bias_corrected_laplacian(op, g).col(0) - exact).cwiseAbs().maxCoeff() / scale;
    EXPECT_NEAR(plain, x / 2, 0.1 * x / 2) << "m = " << m;
    EXPECT_LE(corrected, (5.0 / 6.0) * x * x + 8e-4) << "m = " << m;
    EXPECT_LE(corrected, 0.3 * plain) << "m = " << m;
  }
}

}  // namespace
