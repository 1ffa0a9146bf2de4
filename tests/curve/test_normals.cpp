// Integral Invariant normals: exactness of the O(R/h) moments, convergence, determinism.
#include "digilap/core/error.hpp"
#include "digilap/curve/normals.hpp"

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstring>

using namespace digilap;

namespace {

double max_angle_error(const LinelNormals& a, const LinelNormals& b) {
  double worst = 0;
  for (std::size_t c = 0; c < a.size(); ++c)
    for (Eigen::Index i = 0; i < a[c].rows(); ++i)
      worst = std::max(worst, std::acos(std::min(1.0, a[c].row(i).dot(b[c].row(i)))));
  return worst;
}

// Brute-force II normal: loop over every pixel of the disk's bounding square.
Eigen::Vector2d brute_normal(const DigitalSet& set, const Eigen::Vector2d& centre, double R,
                             const Eigen::Vector2d& trivial) {
  const double h = set.h();
  double n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  for (int j = static_cast<int>(std::floor((centre.y() - R) / h)) - 1; j <= (centre.y() + R) / h + 1; ++j)
    for (int i = static_cast<int>(std::floor((centre.x() - R) / h)) - 1; i <= (centre.x() + R) / h + 1; ++i) {
      const Eigen::Vector2d z(i * h, j * h);
      if ((z - centre).norm() > R || !set.contains(i, j)) continue;
      n += 1, sx += z.x(), sy += z.y(), sxx += z.x() * z.x(), syy += z.y() * z.y(), sxy += z.x() * z.y();
    }
  Eigen::Matrix2d cov;
  cov << sxx / n - sx * sx / n / n, sxy / n - sx * sy / n / n, sxy / n - sx * sy / n / n, syy / n - sy * sy / n / n;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
  Eigen::Vector2d v = eig.eigenvectors().col(0);
  return v.dot(trivial) < 0 ? Eigen::Vector2d(-v) : v;
}

}  // namespace

TEST(Normals, RowMomentsEqualBruteForcePixelLoop) {
  Flower flower;
  const double h = 0.02;
  const DigitalSet set = digitize(flower, h);
  const ContourSet cs = track_contours(set);
  const IINormalOptions opt{1.0, 1.0};  // R = h^(1/3): l = 1
  const LinelNormals fast = ii_normals(set, cs, opt);
  const double R = std::cbrt(h);
  double worst = 0;
  for (std::size_t i = 0; i < cs.contours[0].size(); i += 7) {
    const Eigen::Vector2d b = brute_normal(set, cs.linel_midpoint(0, i), R, linel_normal(cs.contours[0].steps[i]));
    worst = std::max(worst, (b - fast[0].row(i).transpose()).norm());
  }
  // Same pixels, same covariance: only rounding differs (the brute force sums ~1e3 doubles).
  EXPECT_LT(worst, 1e-9);
}

TEST(Normals, IIErrorDecreasesWithHOnTheFlower) {
  Flower flower;
  double previous = 1e300;
  for (double h : {0.05, 0.01, 0.002}) {
    const DigitalSet set = digitize(flower, h);
    const ContourSet cs = track_contours(set);
    const double err = max_angle_error(ii_normals(set, cs), exact_normals(flower, cs));
    EXPECT_LT(err, previous) << "h = " << h;
    previous = err;
    if (h == 0.002) EXPECT_LT(err, 0.05);
  }
}

TEST(Normals, ExactNormalsOfTheCircleAreRadial) {
  Circle circle(1.0);
  const DigitalSet set = digitize(circle, 0.05);
  const ContourSet cs = track_contours(set);
  const LinelNormals n = exact_normals(circle, cs);
  for (std::size_t i = 0; i < cs.contours[0].size(); ++i)
    EXPECT_LT((n[0].row(i).transpose() - cs.linel_midpoint(0, i).normalized()).norm(), 1e-13);
}

TEST(Normals, StraightEdgesGiveAxisNormals) {
  // A 60 x 60 square: away from its corners the disk sees a half-plane.
  std::vector<std::uint8_t> bits(60 * 60, 1);
  const DigitalSet set = DigitalSet::from_bitmap(0.01, 60, 60, bits);
  const ContourSet cs = track_contours(set);
  const LinelNormals n = ii_normals(set, cs, {0.5});  // R = 0.5 * 0.01^(1/3) = 0.108 = 10.8 pixels
  const double R = 0.5 * std::cbrt(0.01);
  int checked = 0;
  for (std::size_t i = 0; i < cs.contours[0].size(); ++i) {
    const Eigen::Vector2d m = cs.linel_midpoint(0, i);
    const double to_corner_x = std::min(std::abs(m.x() + 0.005), std::abs(m.x() - 0.595));
    const double to_corner_y = std::min(std::abs(m.y() + 0.005), std::abs(m.y() - 0.595));
    if (std::max(to_corner_x, to_corner_y) < R + 0.02 && std::min(to_corner_x, to_corner_y) < 1e-9) {
      if (to_corner_x > R + 0.02 || to_corner_y > R + 0.02) {
      } else continue;
    }
    if (std::min(to_corner_x, to_corner_y) > 1e-9) continue;
    if (std::max(to_corner_x, to_corner_y) < R + 0.02) continue;
    EXPECT_LT((n[0].row(i).transpose() - linel_normal(cs.contours[0].steps[i])).norm(), 1e-15);
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST(Normals, IdenticalForOneAndTwoThreads) {
  Flower flower;
  const DigitalSet set = digitize(flower, 0.005);
  const ContourSet cs = track_contours(set);
  omp_set_num_threads(1);
  const LinelNormals one = ii_normals(set, cs);
  omp_set_num_threads(2);
  const LinelNormals two = ii_normals(set, cs);
  ASSERT_EQ(one[0].rows(), two[0].rows());
  EXPECT_EQ(std::memcmp(one[0].data(), two[0].data(), sizeof(double) * one[0].size()), 0);
}

TEST(Normals, BadRadiusIsRefused) {
  const DigitalSet set = digitize(Circle(1.0), 0.1);
  const ContourSet cs = track_contours(set);
  EXPECT_THROW(ii_normals(set, cs, {0.0}), Error);
  EXPECT_THROW(ii_normals(set, cs, {-1.0}), Error);
  EXPECT_THROW(ii_normals(set, cs, {std::nan("")}), Error);
  try {
    ii_normals(set, cs, {100.0});
    FAIL() << "no exception";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("exceeds the whole set"), std::string::npos) << e.what();
  }
}
