// curve/ground_truth.hpp: the exact test functions and their Laplace-Beltrami on a posed circle
// against closed forms, closest-point sampling, and the factory's refusals (SPEC §5).
#include "digilap/curve/ground_truth.hpp"
#include "digilap/core/constants.hpp"
#include "digilap/core/error.hpp"
#include "digilap/curve/shapes.hpp"
#include "error_of.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace digilap;

namespace {
// A circle of radius r placed off the origin and turned: p = c + r (cos phi, sin phi), phi the
// angle about c. Along it d/ds = (1/r) d/dphi, so Delta g = (1/r^2) d^2 g / dphi^2.
constexpr double kR = 1.7;
const Eigen::Vector2d kC(0.31, -0.12);
Circle posed_circle() {
  Circle c(kR);
  c.set_pose(kC, 0.4);
  return c;
}
double phi_of(const Shape& s, double theta) {
  const Eigen::Vector2d u = s.point(theta) - kC;
  return std::atan2(u.y(), u.x());
}
}  // namespace

// x^2 = (cx + r cos phi)^2: d^2/dphi^2 = -2 r cos phi (cx + r cos phi) + 2 r^2 sin^2 phi.
// x y: d^2/dphi^2 = -cx r sin phi - cy r cos phi - 2 r^2 sin 2 phi. Tolerance 1e-12: the
// curvature vector and tangent are computed from the parametrization's derivatives.
TEST(GroundTruth, AmbientFunctionsOnACircleHaveTheClosedFormLaplacian) {
  const Circle c = posed_circle();
  const TestFunction x2 = ambient_x2(), xy = ambient_xy();
  for (double theta = 0; theta < 2 * kPi; theta += 0.37) {
    const double f = phi_of(c, theta), cs = std::cos(f), sn = std::sin(f);
    const double x = kC.x() + kR * cs, y = kC.y() + kR * sn;
    EXPECT_NEAR(x2.value(c, theta), x * x, 1e-12);
    EXPECT_NEAR(x2.laplacian(c, theta), (-2 * kR * cs * x + 2 * kR * kR * sn * sn) / (kR * kR), 1e-12) << theta;
    EXPECT_NEAR(xy.value(c, theta), x * y, 1e-12);
    EXPECT_NEAR(xy.laplacian(c, theta), (-kC.x() * kR * sn - kC.y() * kR * cs - 2 * kR * kR * std::sin(2 * f)) / (kR * kR), 1e-12)
        << theta;
  }
}

// cos(2 pi m s / P) is an eigenfunction: Delta g = -(2 pi m / P)^2 g, P = 2 pi r.
TEST(GroundTruth, IntrinsicCosinesAreEigenfunctions) {
  const Circle c = posed_circle();
  EXPECT_NEAR(c.length(), 2 * kPi * kR, 1e-12);
  for (int m : {1, 3, 7}) {
    const TestFunction g = make_test_function("cos" + std::to_string(m));
    EXPECT_EQ(g.name, "cos" + std::to_string(m));
    for (double theta = 0.05; theta < 2 * kPi; theta += 0.41)
      EXPECT_NEAR(g.laplacian(c, theta), -(m / kR) * (m / kR) * g.value(c, theta), 1e-12) << "m = " << m;
  }
}

// Points off the circle along its normals: the closest point and the radial projection are the
// circle's point at the same angle about the centre.
TEST(GroundTruth, ClosestPointSamplingProjectsAlongTheNormal) {
  const Circle c = posed_circle();
  Eigen::MatrixX2d positions(12, 2);
  Eigen::VectorXd angles(12);
  for (int i = 0; i < 12; ++i) {
    angles[i] = -3 + 0.5 * i;
    positions.row(i) = (kC + (kR + 0.05 * (i % 3 - 1)) * Eigen::Vector2d(std::cos(angles[i]), std::sin(angles[i]))).transpose();
  }
  for (Sampling sampling : {Sampling::ClosestPoint, Sampling::Radial}) {
    const Eigen::VectorXd theta = sample_parameters(c, positions, sampling);
    for (int i = 0; i < 12; ++i) {
      const Eigen::Vector2d expected = kC + kR * Eigen::Vector2d(std::cos(angles[i]), std::sin(angles[i]));
      EXPECT_LT((c.point(theta[i]) - expected).norm(), 1e-9) << "row " << i;
    }
    const Eigen::VectorXd values = sample_values(c, ambient_x2(), theta), laplacians = sample_laplacian(c, ambient_x2(), theta);
    for (int i = 0; i < 12; ++i) {
      EXPECT_EQ(values[i], ambient_x2().value(c, theta[i]));
      EXPECT_EQ(laplacians[i], ambient_x2().laplacian(c, theta[i]));
    }
  }
}

// The curvature vector of a circle points to its centre with length 1 / r.
TEST(GroundTruth, CurvatureVectorOfACircle) {
  const Circle c = posed_circle();
  for (double theta = 0; theta < 2 * kPi; theta += 0.5)
    EXPECT_LT((curvature_vector(c, theta) - (kC - c.point(theta)) / (kR * kR)).norm(), 1e-12) << theta;
}

TEST(GroundTruth, UnknownFunctionsAreRefusedListingTheKnownOnes) {
  EXPECT_NE(error_of([] { make_test_function("x3"); }).find("known: cos1 .. cos9, x2, xy"), std::string::npos);
  EXPECT_THROW(make_test_function("cos10"), Error);
  EXPECT_THROW(intrinsic_cosine(-1), Error);
}
