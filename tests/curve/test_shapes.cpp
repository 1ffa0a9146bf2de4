// Shapes: exact geometry checked against independent computations.
#include "digilap/core/error.hpp"
#include "digilap/curve/shapes.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace digilap;

namespace {

constexpr double kPi = 3.14159265358979323846;

// Independent arclength: composite Simpson on [a, b] with n panels, long double accumulation.
double simpson_length(const Shape& s, double a, double b, int n) {
  const double w = (b - a) / n;
  long double sum = 0;
  for (int k = 0; k < n; ++k) {
    const double x = a + k * w;
    sum += (s.derivative(x).norm() + 4.0 * s.derivative(x + 0.5 * w).norm() + s.derivative(x + w).norm());
  }
  return static_cast<double>(sum * w / 6.0L);
}

std::vector<std::unique_ptr<Shape>> all_shapes() {
  std::vector<std::unique_ptr<Shape>> shapes;
  for (const auto& n : shape_names()) shapes.push_back(make_shape(n));
  auto posed = std::make_unique<Flower>(1.5, 0.3, 3, 0.2);
  posed->set_pose({0.3, -0.7}, 0.4);
  shapes.push_back(std::move(posed));
  return shapes;
}

}  // namespace

TEST(Shapes, LengthOfCircleAndEllipseMatchClosedForms) {
  EXPECT_NEAR(Circle(1.0).length(), 2 * kPi, 1e-12 * 2 * kPi);
  EXPECT_NEAR(Circle(0.3).length(), 0.6 * kPi, 1e-12 * 0.6 * kPi);
  // Ellipse perimeter 4 a E(e), e^2 = 1 - b^2 / a^2 (complete elliptic integral, C++17).
  const double a = 2, b = 1, exact = 4 * a * std::comp_ellint_2(std::sqrt(1 - b * b / (a * a)));
  EXPECT_NEAR(Ellipse(a, b).length(), exact, 1e-12 * exact);
}

TEST(Shapes, LengthMatchesIndependentQuadratureOnEveryShape) {
  for (const auto& s : all_shapes()) {
    // Simpson with 4e5 panels: error ~ w^4 f'''' below 1e-14 for these analytic curves (the
    // accflower is C^2 at theta = +-pi only, where its derivatives stay bounded).
    const double ref = simpson_length(*s, -kPi, kPi, 400000);
    EXPECT_NEAR(s->length(), ref, 1e-12 * ref) << s->name();
    for (double t : {-2.5, -0.3, 0.0, 1.0, 3.0}) {
      const double part = simpson_length(*s, -kPi, t, 400000);
      EXPECT_NEAR(s->arclength(t), part, 1e-12 * ref) << s->name() << " theta " << t;
    }
  }
}

TEST(Shapes, DerivativesMatchFiniteDifferences) {
  for (const auto& s : all_shapes()) {
    for (double t : {-3.0, -1.2, 0.1, 0.9, 2.7}) {
      const double e = 1e-5;
      const Eigen::Vector2d d1 = (s->point(t + e) - s->point(t - e)) / (2 * e);
      const Eigen::Vector2d d2 = (s->point(t + e) - 2 * s->point(t) + s->point(t - e)) / (e * e);
      // Central differences: O(e^2) = 1e-10 truncation; the second one loses ~1e-16/e^2 = 1e-6.
      EXPECT_LT((d1 - s->derivative(t)).norm(), 1e-7 * (1 + s->derivative(t).norm())) << s->name();
      EXPECT_LT((d2 - s->second_derivative(t)).norm(), 1e-4 * (1 + s->second_derivative(t).norm())) << s->name();
    }
  }
}

TEST(Shapes, InsideTestAgreesWithNormalDirection) {
  for (const auto& s : all_shapes()) {
    for (int k = 0; k < 200; ++k) {
      const double t = -kPi + 2 * kPi * (k + 0.37) / 200;
      const Eigen::Vector2d p = s->point(t), n = s->outward_normal(t);
      EXPECT_TRUE(s->inside(p - 1e-6 * n)) << s->name() << " theta " << t;
      EXPECT_FALSE(s->inside(p + 1e-6 * n)) << s->name() << " theta " << t;
    }
  }
}

TEST(Shapes, ClosestPointMatchesBruteForceDenseSampling) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const auto& s : all_shapes()) {
    // Brute force: 2e5 samples of the curve, the nearest one.
    const int n = 200000;
    std::vector<Eigen::Vector2d> pts(n);
    for (int k = 0; k < n; ++k) pts[k] = s->point(-kPi + 2 * kPi * k / n);
    double spacing = 0;
    for (int k = 1; k < n; ++k) spacing = std::max(spacing, (pts[k] - pts[k - 1]).norm());
    double worst_gap = 0;
    for (int q = 0; q < 300; ++q) {
      // Points near the curve (up to 0.05 away, both sides), where pointels live.
      const double t = -kPi + 2 * kPi * unit(rng);
      const Eigen::Vector2d p = s->point(t) + (unit(rng) - 0.5) * 0.1 * s->outward_normal(t);
      double best = 1e300;
      for (const auto& x : pts) best = std::min(best, (x - p).norm());
      const double theta = s->closest_parameter(p);
      const double d = (s->point(theta) - p).norm();
      // Never farther than the best sample (a sample is a point of the curve) ...
      EXPECT_LE(d, best + 1e-13) << s->name();
      // ... and the brute force is within its sampling error of the true minimum: the true
      // closest point is at most half a sample spacing from a sample.
      worst_gap = std::max(worst_gap, best - d);
      int k_best = 0;
      for (int k = 0; k < n; ++k)
        if ((pts[k] - p).norm() < (pts[k_best] - p).norm()) k_best = k;
      EXPECT_LT((pts[k_best] - s->point(theta)).norm(), spacing) << s->name();
      // The projection is orthogonal.
      EXPECT_LT(std::abs((s->point(theta) - p).dot(s->tangent(theta))), 1e-12) << s->name();
    }
    EXPECT_LE(worst_gap, 0.5 * spacing) << s->name();
  }
}

TEST(Shapes, ClosestPointNearTheSharpestTips) {
  // Accelerated flower with the sharp tips of SPEC §6 (radius of curvature 0.04 near theta = +-pi).
  AccFlower sharp(2.0, 0.5, 3);
  for (int k = 0; k < 100; ++k) {
    const double t = kPi - 0.3 * k / 100.0;
    const Eigen::Vector2d p = sharp.point(t) + 0.01 * sharp.outward_normal(t);
    const double theta = sharp.closest_parameter(p);
    EXPECT_NEAR((sharp.point(theta) - p).norm(), 0.01, 1e-12) << "theta " << t;
  }
}

TEST(Shapes, PoseMovesAndRotatesTheCurve) {
  Flower f;
  Flower g;
  g.set_pose({1.0, 2.0}, 0.5);
  for (double t : {-2.0, 0.0, 1.5}) {
    const Eigen::Vector2d p = f.point(t);
    const Eigen::Vector2d q(std::cos(0.5) * p.x() - std::sin(0.5) * p.y() + 1.0,
                            std::sin(0.5) * p.x() + std::cos(0.5) * p.y() + 2.0);
    EXPECT_LT((g.point(t) - q).norm(), 1e-14);
    EXPECT_NEAR(g.closest_parameter(q), t, 1e-12);
  }
  EXPECT_NEAR(g.length(), f.length(), 1e-12 * f.length());
}

TEST(Shapes, UserPolarCurve) {
  // r = 1 + 0.2 cos(3 theta), given by the user.
  PolarCurve c([](double t) { return 1 + 0.2 * std::cos(3 * t); },
               [](double t) { return -0.6 * std::sin(3 * t); },
               [](double t) { return -1.8 * std::cos(3 * t); }, "trefoil");
  Flower same(1.0, 0.2, 3);
  EXPECT_NEAR(c.length(), same.length(), 1e-13);
  EXPECT_EQ(c.name(), "trefoil");
}

TEST(Shapes, BadParametersAreRefusedClearly) {
  EXPECT_THROW(Circle(-1.0), Error);
  EXPECT_THROW(Circle(std::nan("")), Error);
  EXPECT_THROW(Ellipse(0.0, 1.0), Error);
  EXPECT_THROW(Flower(0.5, 1.0), Error);
  try {
    make_shape("square");
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown shape 'square'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("accflower"), std::string::npos);
  }
}

// Shapes with their own parameters, as the apps take them (issue 12): "name:key=value,...".
TEST(Shapes, ParametersFromText) {
  const auto flower = make_shape("flower:R=1.5,v=0.3,k=4,phase=0.2");
  const Flower expected(1.5, 0.3, 4, 0.2);
  EXPECT_NEAR(flower->length(), expected.length(), 1e-12 * expected.length());
  EXPECT_EQ(make_shape("circle:r=2.5")->length(), Circle(2.5).length());
  EXPECT_NEAR(make_shape("ellipse:b=0.5")->length(), Ellipse(2.0, 0.5).length(), 1e-12);  // a keeps its default
  EXPECT_EQ(make_shape("accflower:k=3")->length(), AccFlower(2.0, 0.25, 3).length());
  for (const char* bad : {"flower:q=1", "flower:R", "circle:r=", "circle:r=1x", "circle:r=nan", "flower:k=0", "flower:k=1.5",
                          "ellipse:a=1,a=2", "circle:r=-1", "flower:R=1,v=1", "hexagon"})
    EXPECT_THROW(make_shape(bad), Error) << bad;
  EXPECT_NE(shape_syntax().find("flower:R=2,v=0.5,k=5,phase=0"), std::string::npos) << shape_syntax();
}
