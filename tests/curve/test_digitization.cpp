// Gauss digitization: exact pixel sets, without a dense bitmap.
#include "digilap/curve/contour.hpp"
#include "digilap/curve/digitization.hpp"
#include "digilap/core/error.hpp"

#include "error_of.hpp"

#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <functional>

using namespace digilap;

namespace {
constexpr double kPi = 3.14159265358979323846;

// Independent count: integer points with i^2 + j^2 < n^2 (strictly inside the circle of radius
// n pixels), in exact integer arithmetic.
long long lattice_points_inside(long long n) {
  long long count = 0;
  for (long long i = -n; i <= n; ++i)
    for (long long j = -n; j <= n; ++j) count += (i * i + j * j < n * n);
  return count;
}
}  // namespace

TEST(Digitization, CircleCountsEqualExactLatticeCounts) {
  EXPECT_EQ(digitize(Circle(1.0), 0.1).pixel_count(), lattice_points_inside(10));
  EXPECT_EQ(digitize(Circle(1.0), 0.01).pixel_count(), lattice_points_inside(100));
}

TEST(Digitization, AreaConvergesToPiRSquared) {
  double previous = 1e300;
  for (double h : {0.1, 0.03, 0.01, 0.003, 0.001}) {
    const double area = h * h * digitize(Circle(1.0), h).pixel_count();
    const double err = std::abs(area - kPi);
    // Every misclassified pixel lies within h/sqrt(2) of the curve: |error| <= P h / sqrt(2) * h/h.
    EXPECT_LE(err, 2 * kPi * h / std::sqrt(2.0)) << "h = " << h;
    previous = std::min(previous, err);
  }
  EXPECT_LT(previous, 1e-4);
}

TEST(Digitization, AgreesPixelByPixelWithTheInsideTest) {
  for (const auto& name : shape_names()) {
    auto shape = make_shape(name);
    if (name == "flower") shape->set_pose({0.013, -0.021}, 0.3);  // off-grid, rotated
    const double h = 0.05;
    const DigitalSet set = digitize(*shape, h);
    const auto box = shape->bounding_box();
    long long expected = 0, mismatches = 0;
    for (long long j = std::floor(box.min().y() / h) - 2; j <= std::ceil(box.max().y() / h) + 2; ++j)
      for (long long i = std::floor(box.min().x() / h) - 2; i <= std::ceil(box.max().x() / h) + 2; ++i) {
        const bool in = shape->inside({i * h, j * h});
        expected += in;
        mismatches += (in != set.contains(static_cast<int>(i), static_cast<int>(j)));
      }
    EXPECT_EQ(mismatches, 0) << name;
    EXPECT_EQ(set.pixel_count(), expected) << name;
  }
}

TEST(Digitization, FlowerAtOneTenThousandthNeedsMemoryOfTheBoundaryOnly) {
  Flower flower;
  const double h = 1e-4;
  const DigitalSet set = digitize(flower, h);
  // Exact area of a polar curve: (1/2) int r^2 = pi (R^2 + v^2 / 2).
  const double area = kPi * (4.0 + 0.125);
  EXPECT_NEAR(h * h * set.pixel_count(), area, flower.length() * h);
  // A dense bitmap would take 2.5e9 bytes; runs take a few per row: below 4 MB.
  EXPECT_LT(set.memory_bytes(), 4u << 20);
  EXPECT_LE(set.run_count(), 6u * (set.row_end() - set.row_begin()));
}

TEST(Digitization, BitmapAndPixelListConstructors) {
  // 4 x 3 bitmap, rows bottom-up here: row 0 = "1101".
  std::vector<std::uint8_t> bits = {1, 1, 0, 1, 0, 0, 0, 0, 0, 1, 1, 1};
  const DigitalSet a = DigitalSet::from_bitmap(1.0, 4, 3, bits, 10, -5);
  EXPECT_EQ(a.pixel_count(), 6);
  EXPECT_TRUE(a.contains(10, -5));
  EXPECT_FALSE(a.contains(12, -5));
  EXPECT_FALSE(a.contains(10, -4));
  EXPECT_TRUE(a.contains(13, -3));
  EXPECT_EQ(a.row_begin(), -5);
  EXPECT_EQ(a.row_end(), -2);
  const DigitalSet b = DigitalSet::from_pixels(1.0, {{3, 3}, {4, 3}, {3, 3}, {5, 3}, {0, 7}});
  EXPECT_EQ(b.pixel_count(), 4);
  EXPECT_EQ(b.run_count(), 2u);  // {3,4,5} merged into one run
}

TEST(Digitization, BadStepIsRefused) {
  Circle c;
  EXPECT_THROW(digitize(c, 0.0), Error);
  EXPECT_THROW(digitize(c, -0.1), Error);
  EXPECT_THROW(digitize(c, std::nan("")), Error);
  EXPECT_THROW(digitize(c, INFINITY), Error);
  EXPECT_THROW(digitize(c, 1e-12), Error);  // pixel indices beyond 32 bits
  EXPECT_EQ(digitize(c, 5.0).pixel_count(), 1);  // only the centre pixel (0, 0)
}

// Issue 15, item 3: indices at the edges of the int32 range gave a segfault, lost pixels, a
// "hole" of area -8589934590 and bad_alloc. They are refused with the range; the range's own
// edges still track into one counter-clockwise contour of area 1.
TEST(Digitization, PixelIndicesWithoutRoomForNeighboursAreRefused) {
  using P = std::vector<Eigen::Vector2i>;
  for (const P& pixels : {P{{0, INT_MIN}}, P{{INT_MAX, 0}}, P{{0, INT_MAX}}, P{{INT_MIN, 0}}, P{{0, 0}, {kMaxPixelIndex + 1, 0}}}) {
    const std::string message = error_of([&] { DigitalSet::from_pixels(1.0, pixels); });
    EXPECT_NE(message.find("is outside [-1073741824, 1073741824]"), std::string::npos) << message;
  }
  const std::vector<std::uint8_t> bits(4, 1);
  EXPECT_NE(error_of([&] { DigitalSet::from_bitmap(1.0, 2, 2, bits, INT_MAX - 1, 0); }).find("column index"), std::string::npos);
  EXPECT_NE(error_of([&] { DigitalSet::from_bitmap(1.0, 2, 2, bits, 0, INT_MIN); }).find("row index"), std::string::npos);
  EXPECT_NE(error_of([&] { DigitalSet::from_rows(1.0, INT_MAX - 1, {{}, {{0, 1}}}); }).find("row index"), std::string::npos);
  EXPECT_NE(error_of([&] { DigitalSet::from_rows(1.0, 0, {{{INT_MIN, 0}}}); }).find("column index"), std::string::npos);
  // Two pixels 2^31 rows apart: refused with the span before anything is allocated.
  const std::string span = error_of([] { DigitalSet::from_pixels(1.0, {{0, -kMaxPixelIndex}, {0, kMaxPixelIndex}}); });
  EXPECT_NE(span.find("span 2147483649 rows but hold only 2 runs"), std::string::npos) << span;
  for (const Eigen::Vector2i& corner : {Eigen::Vector2i(kMaxPixelIndex, kMaxPixelIndex), Eigen::Vector2i(-kMaxPixelIndex, -kMaxPixelIndex),
                                        Eigen::Vector2i(kMaxPixelIndex, -kMaxPixelIndex)}) {
    const ContourSet cs = track_contours(DigitalSet::from_pixels(1.0, {corner}));
    ASSERT_EQ(cs.contours.size(), 1u);
    EXPECT_EQ(cs.contours[0].size(), 4u);
    EXPECT_EQ(cs.contours[0].twice_signed_area(), 2);
  }
}

// Issue 15, item 6: Flower(2, 0.5, k) for even k touches the row y = -1.5 at x = 0 without
// crossing it (the pixel (0, -1.5/h) lies on the curve, so it is outside): it used to be kept,
// inside a run. Every pixel of the box agrees with Shape::inside.
TEST(Digitization, CurveTouchingARowWithoutCrossingIt) {
  for (int k : {2, 6, 10})
    for (double h : {0.1, 0.05, 0.01}) {
      const Flower flower(2, 0.5, k);
      const DigitalSet set = digitize(flower, h);
      const long long touch = std::llround(-1.5 / h);
      EXPECT_FALSE(set.contains(0, static_cast<int>(touch))) << "k = " << k << ", h = " << h;
      const auto box = flower.bounding_box();
      long long mismatches = 0;
      for (long long j = std::floor(box.min().y() / h) - 1; j <= std::ceil(box.max().y() / h) + 1; ++j)
        for (long long i = std::floor(box.min().x() / h) - 1; i <= std::ceil(box.max().x() / h) + 1; ++i)
          mismatches += flower.inside({i * h, j * h}) != set.contains(static_cast<int>(i), static_cast<int>(j));
      EXPECT_EQ(mismatches, 0) << "k = " << k << ", h = " << h;
    }
}

// ... and a curve whose oscillations its samples cannot resolve (Flower(2, 0.5, 20000) gave 416
// wrong pixels at h = 0.01) is refused when it is built, with the reason.
TEST(Digitization, CurvesTooFineForTheSamplingAreRefused) {
  for (int k : {200, 20000}) {
    const std::string message = error_of([k] { Flower(2, 0.5, k); });
    EXPECT_NE(message.find("the tangent turns by"), std::string::npos) << message;
  }
  EXPECT_NO_THROW(Flower(2, 0.5, 50));
}
