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

// sphere_spectrum: l(l+1) / r^2, each 2l + 1 times.
TEST(SurfaceGroundTruth, SphereSpectrumHasItsMultiplicities) {
  const Eigen::VectorXd s = sphere_spectrum(2.0, 17);
  EXPECT_EQ(s[0], 0.0);
  for (int k = 1; k <= 3; ++k) EXPECT_EQ(s[k], 0.5);   // l = 1: 2 / 4
  for (int k = 4; k <= 8; ++k) EXPECT_EQ(s[k], 1.5);   // l = 2: 6 / 4
  for (int k = 9; k <= 15; ++k) EXPECT_EQ(s[k], 3.0);  // l = 3: 12 / 4
  EXPECT_EQ(s[16], 5.0);
  EXPECT_THROW(sphere_spectrum(1.0, 0), Error);
  EXPECT_THROW(sphere_spectrum(-1.0, 3), Error);
}

// torus_spectrum against closed forms in two limits. A thin torus (r / R = 0.02) is nearly the
// flat torus 2 pi R x 2 pi r, whose eigenvalues are (n / R)^2 + (m / r)^2: the curvature terms
// are O((r / R)^2) = 4e-4 relative on the m modes and O(r / R) = 2% on the n-only ones, which are
// (n / R)^2 (1 + O(r/R)^2) once averaged over phi: asserted within 2e-3 (of max(1, value)). On
// the ring torus R = 1, r = 0.4: sorted, n = 1 twice. (tests/python/test_fem_reference.py checks
// it against the independent 4,096-node solver of the reference module, to 1e-5.)
TEST(SurfaceGroundTruth, TorusSpectrumMatchesTheFlatLimitAndConverges) {
  const double R = 50, r = 1;
  const Eigen::VectorXd s = torus_spectrum(R, r, 40);
  std::vector<double> flat;
  for (int n = -40; n <= 40; ++n)
    for (int m = -3; m <= 3; ++m) flat.push_back(n * n / (R * R) + m * m / (r * r));
  std::sort(flat.begin(), flat.end());
  EXPECT_EQ(s[0], 0.0);
  for (int k = 1; k < 40; ++k) EXPECT_NEAR(s[k], flat[static_cast<std::size_t>(k)], 2e-3 * std::max(1.0, flat[static_cast<std::size_t>(k)])) << k;
  const Eigen::VectorXd ring = torus_spectrum(1.0, 0.4, 20);
  for (int k = 1; k < 20; ++k) EXPECT_GT(ring[k], ring[k - 1] - 1e-12);  // sorted
  EXPECT_NEAR(ring[1], ring[2], 1e-9 * ring[1]);  // n = 1: twice
  EXPECT_THROW(torus_spectrum(0.4, 1.0, 5), Error);
  EXPECT_THROW(torus_spectrum(1.0, 0.4, 0), Error);
}
