// Spectrum: eigenvalues against SPEC §5, M-orthonormality, several contours, clear errors.
#include "digilap/error.hpp"
#include "digilap/spectrum.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <cmath>

using namespace digilap;

namespace {
constexpr double kPi = 3.14159265358979323846;

ContourOperator operator_of(const Shape& shape, double h, const HeatLaplacianOptions& o = {}) {
  const DigitalSet set = digitize(shape, h);
  const ContourSet cs = track_contours(set);
  return heat_laplacian(cs, measures(cs, ii_normals(set, cs)), o);
}
}  // namespace

TEST(Spectrum, CircleEigenvaluesMatchTheHeatKernelFormula) {
  Circle circle;
  const ContourOperator op = operator_of(circle, 0.01);
  SpectrumOptions so;
  so.count = 11;
  const Spectrum s = smallest_eigenpairs(op, so);
  ASSERT_EQ(s.eigenvalues.size(), 11);
  const double P = op.contour_length[0];
  // m = 0 (the constants), then pairs m = 1..5: within 2% of (1 - exp(-omega^2 t)) / t with the
  // estimated length P (SPEC §5: the spectrum's accuracy is that of P).
  EXPECT_LE(std::abs(s.eigenvalues[0]), 1e-8 * s.eigenvalues[1]);
  for (int m = 1; m <= 5; ++m) {
    const double expected = heat_kernel_eigenvalue(m, P, op.t);
    for (int k : {2 * m - 1, 2 * m}) EXPECT_NEAR(s.eigenvalues[k], expected, 0.02 * expected) << "m = " << m;
    const double split = std::abs(s.eigenvalues[2 * m] - s.eigenvalues[2 * m - 1]) / expected;
    // Odd m: the square symmetry of the grid makes the pair exactly degenerate.
    if (m % 2 == 1) EXPECT_LE(split, 1e-8) << "m = " << m;
    RecordProperty("split_m" + std::to_string(m), std::to_string(split));
    std::printf("circle h = 0.01: m = %d, lambda = %.6f, %.6f (formula %.6f), relative split %.2e\n", m,
                s.eigenvalues[2 * m - 1], s.eigenvalues[2 * m], expected, split);
  }
}

TEST(Spectrum, EigenvectorsAreMOrthonormalAndSolveTheProblem) {
  const ContourOperator op = operator_of(Flower(), 0.02);
  const Spectrum s = smallest_eigenpairs(op);
  const Eigen::MatrixXd gram = s.eigenvectors.transpose() * op.mass.asDiagonal() * s.eigenvectors;
  EXPECT_LE((gram - Eigen::MatrixXd::Identity(gram.rows(), gram.cols())).cwiseAbs().maxCoeff(), 1e-9);
  for (Eigen::Index k = 0; k < s.eigenvalues.size(); ++k) {
    const Eigen::VectorXd x = s.eigenvectors.col(k);
    const Eigen::VectorXd residual = -(op.A * x) - s.eigenvalues[k] * op.mass.cwiseProduct(x);
    EXPECT_LE(residual.norm(), 1e-7 * (op.A * x).norm() + 1e-12) << k;
  }
  for (Eigen::Index k = 1; k < s.eigenvalues.size(); ++k) EXPECT_GE(s.eigenvalues[k], s.eigenvalues[k - 1]);
}

TEST(Spectrum, FlowerEigenvaluesWithinOnePercentOfTheExactOnes) {
  Flower flower;
  const ContourOperator op = operator_of(flower, 0.005);
  const Spectrum s = smallest_eigenpairs(op, {11});
  for (int m = 1; m <= 5; ++m) {
    const double exact = std::pow(2 * kPi * m / flower.length(), 2);
    for (int k : {2 * m - 1, 2 * m}) EXPECT_NEAR(s.eigenvalues[k], exact, 0.01 * exact) << "m = " << m;
  }
}

TEST(Spectrum, OneZeroEigenvaluePerContour) {
  // Two discs: two eigenvalues 0 (one constant per contour), then positive ones.
  std::vector<std::uint8_t> bits(50 * 30, 0);
  for (int r = 0; r < 30; ++r)
    for (int c = 0; c < 50; ++c) bits[r * 50 + c] = std::hypot(r - 15, c - 12) < 10 || std::hypot(r - 15, c - 37) < 8;
  const DigitalSet set = DigitalSet::from_bitmap(0.02, 50, 30, bits);
  const ContourSet cs = track_contours(set);
  ASSERT_EQ(cs.contours.size(), 2u);
  const ContourOperator op = heat_laplacian(cs, measures(cs, ii_normals(set, cs, {0.3})));
  const Spectrum s = smallest_eigenpairs(op, {4});
  EXPECT_LE(std::abs(s.eigenvalues[0]), 1e-8 * s.eigenvalues[2]);
  EXPECT_LE(std::abs(s.eigenvalues[1]), 1e-8 * s.eigenvalues[2]);
  EXPECT_GT(s.eigenvalues[2], 1.0);
}

TEST(Spectrum, ClearErrors) {
  const ContourOperator op = operator_of(Circle(), 0.1);
  EXPECT_THROW(smallest_eigenpairs(op, {0}), Error);
  EXPECT_THROW(smallest_eigenpairs(op, {static_cast<int>(op.rows())}), Error);
  Eigen::VectorXd zero_mass = op.mass;
  zero_mass[3] = 0;
  try {
    smallest_eigenpairs(op.A, zero_mass);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("mass of row 3"), std::string::npos) << e.what();
  }
  // A Krylov space barely larger than the request, one restart, an unreachable tolerance:
  // Spectra reports non-convergence, and so do we, with the numbers.
  SpectrumOptions starved;
  starved.count = 10;
  starved.subspace = 11;
  starved.max_iterations = 1;
  starved.tolerance = 1e-16;
  try {
    smallest_eigenpairs(operator_of(Flower(), 0.01), starved);
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("did not converge"), std::string::npos) << e.what();
  }
}
