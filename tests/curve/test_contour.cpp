// Contour tracking: topology, orientation and exact areas.
#include "digilap/curve/contour.hpp"

#include <gtest/gtest.h>

#include <map>
#include <set>

using namespace digilap;

namespace {

// Every linel has the set on its left and the complement on its right.
void expect_oriented(const DigitalSet& set, const ContourSet& cs) {
  for (const auto& c : cs.contours)
    for (std::size_t i = 0; i < c.size(); ++i) {
      const Eigen::Vector2i d = step_vector(c.steps[i]);
      EXPECT_EQ(c.pointels[(i + 1) % c.size()], c.pointels[i] + d);
      // Pixel on the left of the linel from pointel v (corner (v + 1/2)) along d.
      const Eigen::Vector2i v = c.pointels[i];
      const Eigen::Vector2i left_pixel(v.x() + (d.x() - d.y() + 1) / 2, v.y() + (d.y() + d.x() + 1) / 2);
      const Eigen::Vector2i right_pixel(v.x() + (d.x() + d.y() + 1) / 2, v.y() + (d.y() - d.x() + 1) / 2);
      EXPECT_TRUE(set.contains(left_pixel.x(), left_pixel.y()));
      EXPECT_FALSE(set.contains(right_pixel.x(), right_pixel.y()));
    }
}

// Independent count of boundary linels: 4-neighbour pairs with different membership.
long long boundary_linels(const DigitalSet& set, int i0, int i1, int j0, int j1) {
  long long n = 0;
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      n += set.contains(i, j) != set.contains(i + 1, j);
      n += set.contains(i, j) != set.contains(i, j + 1);
    }
  return n;
}

}  // namespace

TEST(Contours, OneCounterClockwiseContourPerReferenceShape) {
  for (const auto& name : shape_names())
    for (double h : {0.05, 0.01}) {
      auto shape = make_shape(name);
      const DigitalSet set = digitize(*shape, h);
      const ContourSet cs = track_contours(set);
      ASSERT_EQ(cs.contours.size(), 1u) << name << " h " << h;
      const Contour& c = cs.contours[0];
      EXPECT_EQ(c.size() % 2, 0u);
      EXPECT_FALSE(c.is_hole());
      // The pointel polygon encloses exactly the pixels' squares.
      EXPECT_EQ(c.twice_signed_area(), 2 * set.pixel_count()) << name;
      expect_oriented(set, cs);
      const auto box = shape->bounding_box();
      EXPECT_EQ(static_cast<long long>(cs.linel_count()),
                boundary_linels(set, static_cast<int>(box.min().x() / h) - 2, static_cast<int>(box.max().x() / h) + 2,
                                static_cast<int>(box.min().y() / h) - 2, static_cast<int>(box.max().y() / h) + 2));
    }
}

TEST(Contours, TwoPixelsTouchingByACornerGiveTwoContours) {
  const DigitalSet set = DigitalSet::from_pixels(1.0, {{0, 0}, {1, 1}});
  const ContourSet cs = track_contours(set);
  ASSERT_EQ(cs.contours.size(), 2u);
  for (const auto& c : cs.contours) {
    EXPECT_EQ(c.size(), 4u);
    EXPECT_EQ(c.twice_signed_area(), 2);
  }
  expect_oriented(set, cs);
}

TEST(Contours, RingGivesAnOuterAndAHoleContour) {
  // 7 x 7 square with a 3 x 3 hole.
  std::vector<std::uint8_t> bits(49, 1);
  for (int r = 2; r <= 4; ++r)
    for (int c = 2; c <= 4; ++c) bits[r * 7 + c] = 0;
  const DigitalSet set = DigitalSet::from_bitmap(0.5, 7, 7, bits);
  const ContourSet cs = track_contours(set);
  ASSERT_EQ(cs.contours.size(), 2u);
  int holes = 0;
  std::int64_t area = 0;
  for (const auto& c : cs.contours) {
    holes += c.is_hole();
    area += c.twice_signed_area();
    EXPECT_EQ(c.size(), c.is_hole() ? 12u : 28u);
  }
  EXPECT_EQ(holes, 1);
  EXPECT_EQ(area, 2 * set.pixel_count());  // 49 - 9 = 40 pixels
  expect_oriented(set, cs);
}

TEST(Contours, SaddleInsideOneContourSeparatesTheCornerPixels) {
  // (0,0) and (1,1) touch by a corner and are joined by a path around (1,0): one contour that
  // passes twice through the saddle pointel (0,0); pixel (1,0) is not a hole (the complement
  // is 8-connected through the saddle).
  const DigitalSet set =
      DigitalSet::from_pixels(1.0, {{0, 0}, {0, -1}, {1, -1}, {2, -1}, {2, 0}, {2, 1}, {1, 1}});
  const ContourSet cs = track_contours(set);
  ASSERT_EQ(cs.contours.size(), 1u);
  const Contour& c = cs.contours[0];
  EXPECT_EQ(c.twice_signed_area(), 14);
  EXPECT_EQ(static_cast<long long>(c.size()), boundary_linels(set, -3, 4, -3, 4));
  int visits = 0;
  for (const auto& p : c.pointels) visits += (p == Eigen::Vector2i(0, 0));
  EXPECT_EQ(visits, 2);
  expect_oriented(set, cs);
}

TEST(Contours, EmptySetHasNoContourAndPositionsUseTheGridStep) {
  EXPECT_TRUE(track_contours(DigitalSet(0.1)).contours.empty());
  const ContourSet cs = track_contours(DigitalSet::from_pixels(0.1, {{0, 0}}));
  ASSERT_EQ(cs.contours.size(), 1u);
  // The single pixel's contour starts at its lower-left corner (-h/2, -h/2) and goes east.
  EXPECT_NEAR(cs.pointel_position(0, 0).x(), -0.05, 1e-17);
  EXPECT_NEAR(cs.pointel_position(0, 0).y(), -0.05, 1e-17);
  EXPECT_EQ(cs.contours[0].steps[0], Step::East);
  EXPECT_NEAR(cs.linel_midpoint(0, 0).x(), 0.0, 1e-17);
  EXPECT_NEAR(cs.linel_midpoint(0, 0).y(), -0.05, 1e-17);
}
