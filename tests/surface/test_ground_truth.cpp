// surface/ground_truth.hpp: the test functions' exact Laplace-Beltrami on a posed sphere against
// the spherical harmonics' closed forms, and the refusals.
#include "digilap/surface/ground_truth.hpp"
#include "error_of.hpp"
#include "support.hpp"

#include <gtest/gtest.h>

#include <random>

using namespace digilap;
using namespace digilap::surface;
using namespace digilap::surface::test_support;

// On a sphere of radius r about c, q_x^2 - r^2 / 3 and q_x q_y are degree-2 harmonics
// (eigenvalue -6 / r^2): Delta_S q_x^2 = 2 - 6 q_x^2 / r^2, Delta_S q_x q_y = -6 q_x q_y / r^2.
// Positions off the sphere are projected first. Tolerance 1e-12: rounding of the formula.
TEST(SurfaceGroundTruth, SphericalHarmonicsHaveTheirEigenvalues) {
  const double r = 1.7;
  Sphere sphere(r);
  sphere.set_pose(kCentre, Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix());
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  Eigen::MatrixX3d positions(50, 3);
  for (Eigen::Index i = 0; i < positions.rows(); ++i) {
    const Eigen::Vector3d d = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    positions.row(i) = (kCentre + (r + 0.1 * normal(rng)) * d).transpose();
  }
  const SurfaceTestSamples x2 = sample_test_function(sphere, "x2", positions), xy = sample_test_function(sphere, "xy", positions);
  for (Eigen::Index i = 0; i < positions.rows(); ++i) {
    const Eigen::Vector3d q = r * (positions.row(i).transpose() - kCentre).normalized();
    EXPECT_NEAR(x2.values[i], q.x() * q.x(), 1e-12);
    EXPECT_NEAR(x2.laplacians[i], 2 - 6 * q.x() * q.x() / (r * r), 1e-12) << i;
    EXPECT_NEAR(xy.values[i], q.x() * q.y(), 1e-12);
    EXPECT_NEAR(xy.laplacians[i], -6 * q.x() * q.y() / (r * r), 1e-12) << i;
  }
  // The error figure: 0 for the exact values, the relative max deviation otherwise.
  EXPECT_EQ(relative_max_error(x2.laplacians, x2), 0.0);
  const double scale = x2.laplacians.cwiseAbs().maxCoeff();
  EXPECT_NEAR(relative_max_error(x2.laplacians + Eigen::VectorXd::Constant(50, 0.01 * scale), x2), 0.01, 1e-15);
}

TEST(SurfaceGroundTruth, UnknownFunctionsAndSizesAreRefused) {
  const Sphere sphere;
  EXPECT_NE(error_of([&] { sample_test_function(sphere, "cos1", Eigen::MatrixX3d::Zero(2, 3)); }).find("x2 and xy"), std::string::npos);
  const SurfaceTestSamples s = sample_test_function(sphere, "x2", Eigen::MatrixX3d::Ones(3, 3));
  EXPECT_THROW(relative_max_error(Eigen::VectorXd::Zero(2), s), Error);
}
