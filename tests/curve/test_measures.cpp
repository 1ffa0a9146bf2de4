// Measures: lengths converge to the exact length, arclength and distances are consistent.
#include "digilap/core/error.hpp"
#include "digilap/curve/measures.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace digilap;

TEST(Measures, EstimatedLengthOfTheFlowerConverges) {
  Flower flower;
  const double h = 0.002;
  const DigitalSet set = digitize(flower, h);
  const ContourSet cs = track_contours(set);
  const Measures ii = measures(cs, ii_normals(set, cs));
  EXPECT_LT(std::abs(ii.total_length() - flower.length()) / flower.length(), 1e-3);
  EXPECT_EQ(ii.clamped, 0u);
  // With exact normals the projected lengths are better still (the staircase's length is
  // 4/pi times too long; mu undoes exactly that).
  const Measures ex = measures(cs, exact_normals(flower, cs));
  EXPECT_LT(std::abs(ex.total_length() - flower.length()) / flower.length(), 1e-4);
  const double staircase = h * cs.linel_count();
  EXPECT_GT(staircase / flower.length(), 1.1);
}

TEST(Measures, VertexMeasuresArclengthAndDistances) {
  Circle circle;
  const DigitalSet set = digitize(circle, 0.05);
  const ContourSet cs = track_contours(set);
  const Measures m = measures(cs, ii_normals(set, cs));
  const ContourMeasures& c = m.contours[0];
  EXPECT_NEAR(c.vertex_mu.sum(), c.linel_mu.sum(), 1e-12);
  EXPECT_NEAR(c.length, c.linel_mu.sum(), 1e-12);
  EXPECT_EQ(c.S[0], 0.0);
  const auto n = static_cast<std::size_t>(c.S.size());
  for (std::size_t i = 1; i < n; ++i) EXPECT_GE(c.S[i], c.S[i - 1]);
  EXPECT_NEAR(c.vertex_mu[0], 0.5 * (c.linel_mu[n - 1] + c.linel_mu[0]), 1e-16);
  for (std::size_t i : {0ul, 10ul, n / 3}) {
    for (std::size_t j : {1ul, n / 2, n - 1}) {
      EXPECT_EQ(c.geodesic_distance(i, j), c.geodesic_distance(j, i));
      EXPECT_LE(c.geodesic_distance(i, j), c.length / 2);
    }
  }
  EXPECT_NEAR(c.geodesic_distance(0, n - 1), c.linel_mu[n - 1], 1e-12);
}

TEST(Measures, NormalsOrthogonalOrOppositeToTheLinelAreClampedAndCounted) {
  const DigitalSet set = digitize(Circle(1.0), 0.1);
  const ContourSet cs = track_contours(set);
  LinelNormals normals = exact_normals(Circle(1.0), cs);
  const Contour& c = cs.contours[0];
  // Linel 0 gets a normal along the linel (<n, n_e> = 0), linel 1 the opposite of n_e.
  const Eigen::Vector2i d = step_vector(c.steps[0]);
  normals[0].row(0) << d.x(), d.y();
  normals[0].row(1) = -linel_normal(c.steps[1]).transpose();
  const Measures m = measures(cs, normals);
  EXPECT_EQ(m.clamped, 2u);
  // The name of earlier releases (deprecated, issue 21) keeps the count for one release.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
  EXPECT_EQ(m.clamped_linels, 2u);
#pragma GCC diagnostic pop
  EXPECT_EQ(m.contours[0].linel_mu[0], 0.0);
  EXPECT_EQ(m.contours[0].linel_mu[1], 0.0);
  EXPECT_GT(m.contours[0].linel_mu[2], 0.0);  // the others are untouched
}

TEST(Measures, TooWideDiskBreaksTheNormalsInTheValleys) {
  // SPEC §2: R = 2 h^(1/3) (k_R = 2 with l = 1, the former default scale) makes the disk wider
  // than the flower's valleys (radius of curvature 0.2);
  // the estimated normals there point the wrong way although they stay oriented along n_e.
  Flower flower;
  const DigitalSet set = digitize(flower, 0.01);
  const ContourSet cs = track_contours(set);
  const LinelNormals wide = ii_normals(set, cs, {2.0, 1.0}), exact = exact_normals(flower, cs);
  double worst = 0;
  for (Eigen::Index i = 0; i < wide[0].rows(); ++i) worst = std::max(worst, std::acos(std::min(1.0, wide[0].row(i).dot(exact[0].row(i)))));
  EXPECT_GT(worst, 1.5);
}

TEST(Measures, MismatchedNormalsAreRefused) {
  const DigitalSet set = digitize(Circle(1.0), 0.1);
  const ContourSet cs = track_contours(set);
  EXPECT_THROW(measures(cs, LinelNormals{}), Error);
  LinelNormals wrong(1, Eigen::MatrixX2d::Zero(3, 2));
  EXPECT_THROW(measures(cs, wrong), Error);
}
