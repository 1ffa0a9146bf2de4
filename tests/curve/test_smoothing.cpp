// Smoothing: a noisy digitized circle becomes rounder; the area is kept when asked.
#include "digilap/core/error.hpp"
#include "digilap/curve/smoothing.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

using namespace digilap;

namespace {
// A circle of radius 1 whose boundary pixels are randomly in or out: |p| < 1 + 0.01 u, u
// uniform in [-1, 1] per pixel. Returns the operator of its largest contour.
ContourOperator noisy_circle(double h) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector2i> pixels;
  const int n = static_cast<int>(1.2 / h);
  for (int j = -n; j <= n; ++j)
    for (int i = -n; i <= n; ++i)
      if (std::hypot(i * h, j * h) < 1.0 + 0.01 * u(rng)) pixels.emplace_back(i, j);
  const DigitalSet set = DigitalSet::from_pixels(h, pixels);
  ContourSet cs = track_contours(set);
  std::size_t largest = 0;
  for (std::size_t c = 0; c < cs.contours.size(); ++c)
    if (cs.contours[c].size() > cs.contours[largest].size()) largest = c;
  ContourSet main;
  main.h = h;
  main.contours.push_back(cs.contours[largest]);
  // The parameters the tests below were written for: t = 0.03 h^(2/3), R = h^(1/3) (l = 1).
  HeatLaplacianOptions o;
  o.c_t = 0.03;
  o.length_scale = 1.0;
  return heat_laplacian(main, measures(main, ii_normals(set, main, {1.0, 1.0})), o);
}
}  // namespace

TEST(Smoothing, NoisyCircleGetsRounderAndKeepsItsArea) {
  const ContourOperator op = noisy_circle(0.005);
  const Eigen::Index n = op.rows();
  const double before = roundness(op.positions, Eigen::VectorXd::Ones(n));
  ContourSmoothingOptions o;
  o.tau = 1e-2;  // 7 t (t = 0.03 h^(2/3) = 1.4e-3): noise damped by exp(-7), the circle kept
  o.steps = 4;
  const Eigen::MatrixX2d p = smooth_positions(op, o);
  const double after = roundness(p, Eigen::VectorXd::Ones(n));
  // The noise goes; what remains is the digital circle's own 4-fold anisotropy (an O(h/4)
  // radial wobble between axis and diagonal directions), hence a factor 2, not more.
  EXPECT_LT(after, 0.6 * before) << "roundness " << before << " -> " << after;
  std::printf("noisy circle h = 0.005: roundness %.5f -> %.5f\n", before, after);
  // Area kept to rounding by the rescaling (the scale is sqrt(A_before / A_after) exactly).
  const double a0 = enclosed_areas(op, op.positions)[0], a1 = enclosed_areas(op, p)[0];
  EXPECT_NEAR(a1, a0, 1e-12 * a0);
  // Without rescaling the flow shrinks the curve: the circle's x, y (eigenvalue ~1) by
  // exp(-tau) each, so the area by about exp(-2 tau); the staircase's zig-zag, flattened,
  // gives some back. Between the two: it shrinks, by less than exp(-4 tau).
  // The name of earlier releases (deprecated, issue 21) still switches the rescaling off, and
  // the earlier roundness of a row range is the core's with equal weights.
  ContourSmoothingOptions earlier = o;
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
  earlier.preserve_area = false;
  EXPECT_EQ(roundness(p, 0, n), after);
#pragma GCC diagnostic pop
  EXPECT_EQ(enclosed_areas(op, smooth_positions(op, earlier))[0], [&] {
    ContourSmoothingOptions renamed = o;
    renamed.preserve_size = false;
    return enclosed_areas(op, smooth_positions(op, renamed))[0];
  }());
  o.preserve_size = false;
  const double a2 = enclosed_areas(op, smooth_positions(op, o))[0];
  EXPECT_LT(a2, a0 * std::exp(-0.5 * o.tau));
  EXPECT_GT(a2, a0 * std::exp(-4 * o.tau));
}

TEST(Smoothing, FunctionNoiseIsDampedAndTheMeanKept) {
  const ContourOperator op = noisy_circle(0.01);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.1);
  Eigen::VectorXd f(op.rows()), clean(op.rows());
  for (Eigen::Index r = 0; r < op.rows(); ++r) {
    clean[r] = std::cos(std::atan2(op.positions(r, 1), op.positions(r, 0)));
    f[r] = clean[r] + noise(rng);
  }
  // tau = 5e-3 = 2.3 t: white noise damped by about exp(-2.3) = 0.1, cos(theta) (eigenvalue 1)
  // by exp(-5e-3), a 0.5% bias.
  const Eigen::VectorXd g = smooth_function(op, f, 5e-3, 2);
  EXPECT_LT((g - clean).norm(), 0.25 * (f - clean).norm());
  EXPECT_NEAR(op.mass.dot(g), op.mass.dot(f), 1e-12 * op.mass.sum());
  EXPECT_THROW(smooth_function(op, f, 0.0), Error);
  EXPECT_THROW(smooth_function(op, f, 1e-3, 0), Error);
  EXPECT_THROW(smooth_function(op, Eigen::VectorXd::Zero(3), 1e-3), Error);
}
