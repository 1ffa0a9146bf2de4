// core/smoothing.hpp: diffusion of functions on any operator's rows and the roundness of
// weighted points, against exact values.
#include "digilap/core/smoothing.hpp"
#include "digilap/core/constants.hpp"
#include "digilap/core/error.hpp"
#include "error_of.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace digilap;

namespace {
// (A, M) of a ring of n nodes, M = c I and A = c (the ring's graph Laplacian, negative): the
// generalized eigenvectors are cos(2 pi m i / n), eigenvalue -(2 - 2 cos(2 pi m / n)) whatever c.
struct Ring {
  SparseMatrix A;
  Eigen::VectorXd mass;
};
Ring ring(int n, double c) {
  std::vector<Eigen::Triplet<double>> entries;
  for (int i = 0; i < n; ++i) {
    entries.emplace_back(i, i, -2 * c);
    entries.emplace_back(i, (i + 1) % n, c);
    entries.emplace_back(i, (i + n - 1) % n, c);
  }
  Ring r;
  r.A.resize(n, n);
  r.A.setFromTriplets(entries.begin(), entries.end());
  r.mass = Eigen::VectorXd::Constant(n, c);
  return r;
}
}  // namespace

// Implicit Euler with dt = tau / steps multiplies an eigenvector of eigenvalue -lambda by
// (1 + dt lambda)^(-steps) exactly (to the solver's rounding, 1e-13 relative here); a constant
// is kept. With M = 0.3 I, a flow that ignored M would give (1 + 0.3 dt lambda)^(-steps).
TEST(CoreSmoothing, EigenvectorsDecayByTheImplicitEulerFactor) {
  const int n = 64, m = 5;
  const Ring r = ring(n, 0.3);
  Eigen::MatrixXd f(n, 2);
  for (int i = 0; i < n; ++i) f(i, 0) = std::cos(2 * kPi * m * i / n), f(i, 1) = 1.0;
  const double tau = 0.7, lambda = 2 - 2 * std::cos(2 * kPi * m / n);
  const int steps = 4;
  const Eigen::MatrixXd g = smooth(r.A, r.mass, f, tau, steps);
  const double factor = std::pow(1 + tau / steps * lambda, -steps);
  EXPECT_LT((g.col(0) - factor * f.col(0)).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_LT((g.col(1) - f.col(1)).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(CoreSmoothing, BadTimesStepsAndSizesAreRefused) {
  const Ring r = ring(8, 1.0);
  const Eigen::MatrixXd f = Eigen::MatrixXd::Ones(8, 1);
  EXPECT_NE(error_of([&] { smooth(r.A, r.mass, f, 0.0, 1); }).find("tau must be > 0 and finite"), std::string::npos);
  EXPECT_THROW(smooth(r.A, r.mass, f, std::nan(""), 1), Error);
  EXPECT_NE(error_of([&] { smooth(r.A, r.mass, f, 1.0, 0); }).find("steps >= 1"), std::string::npos);
  EXPECT_NE(error_of([&] { smooth(r.A, r.mass, Eigen::MatrixXd::Ones(7, 1), 1.0, 1); }).find("7 rows"), std::string::npos);
}

// Four points at distances 1, 1, 3, 3 from their weighted centroid (the origin), weights 3, 3,
// 1, 1: mean distance 1.5, variance (6 * 0.25 + 2 * 2.25) / 8 = 0.75, roundness sqrt(0.75) / 1.5
// = 1 / sqrt(3). Equal weights: mean 2, standard deviation 1, roundness 1 / 2.
TEST(CoreSmoothing, RoundnessOfWeightedPointsIsExact) {
  Eigen::MatrixXd p(4, 2);
  p << 1, 0, -1, 0, 0, 3, 0, -3;
  EXPECT_NEAR(roundness(p, Eigen::Vector4d(3, 3, 1, 1)), 1 / std::sqrt(3.0), 1e-15);
  EXPECT_NEAR(roundness(p, Eigen::Vector4d::Ones()), 0.5, 1e-15);
  // Invariant under translation and scaling; the same in 3D (a third coordinate of zeros).
  const Eigen::MatrixXd moved = (2.5 * p).rowwise() + Eigen::RowVector2d(10, -4);
  EXPECT_NEAR(roundness(moved, Eigen::Vector4d(3, 3, 1, 1)), 1 / std::sqrt(3.0), 1e-14);
  Eigen::MatrixXd p3 = Eigen::MatrixXd::Zero(4, 3);
  p3.leftCols(2) = p;
  EXPECT_NEAR(roundness(p3, Eigen::Vector4d(3, 3, 1, 1)), 1 / std::sqrt(3.0), 1e-15);
  // Points on a sphere, any weights: 0 to rounding.
  Eigen::MatrixXd s(6, 3);
  s << 2, 0, 0, -2, 0, 0, 0, 2, 0, 0, -2, 0, 0, 0, 2, 0, 0, -2;
  EXPECT_LT(roundness(s, (Eigen::VectorXd(6) << 1, 1, 2, 2, 5, 5).finished()), 1e-15);
}

TEST(CoreSmoothing, RoundnessRefusesTooFewPointsAndBadWeights) {
  const Eigen::MatrixXd p = Eigen::MatrixXd::Random(5, 2);
  EXPECT_NE(error_of([&] { roundness(p.topRows(2), Eigen::Vector2d::Ones()); }).find("at least 3 points"), std::string::npos);
  EXPECT_NE(error_of([&] { roundness(p, Eigen::Vector4d::Ones()); }).find("5 points and 4 weights"), std::string::npos);
  EXPECT_NE(error_of([&] { roundness(p, -Eigen::VectorXd::Ones(5)); }).find(">= 0 and finite"), std::string::npos);
  EXPECT_THROW(roundness(p, Eigen::VectorXd::Zero(5)), Error);
  EXPECT_THROW(roundness(p, Eigen::VectorXd::Constant(5, std::nan(""))), Error);
}
