// core/runs.hpp: runs of a grid row and the index bound both dimensions' sets enforce; the
// internal run helpers (lib/core/runs.hpp) that 2D and 3D share.
#include "digilap/core/runs.hpp"
#include "digilap/core/error.hpp"
#include "digilap/curve/digitization.hpp"
#include "digilap/surface/digitization.hpp"
#include "core/runs.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <vector>

using namespace digilap;

// Indices, their neighbours and run ends fit in 32 bits; a row across the whole range holds
// 2^31 + 1 pixels, counted in 64 bits (it was -2147483647: the length overflowed in int).
TEST(CoreRuns, IndicesFitIn32BitsAndLengthsAreCountedIn64) {
  EXPECT_LT(static_cast<std::int64_t>(kMaxPixelIndex) + 2, std::numeric_limits<std::int32_t>::max());
  EXPECT_GT(-static_cast<std::int64_t>(kMaxPixelIndex) - 2, std::numeric_limits<std::int32_t>::min());
  const std::int64_t whole = 2 * static_cast<std::int64_t>(kMaxPixelIndex) + 1;
  EXPECT_EQ(DigitalSet::from_rows(1.0, 0, {{{-kMaxPixelIndex, kMaxPixelIndex + 1}}}).pixel_count(), whole);
  EXPECT_EQ(surface::VoxelSet::from_rows(1.0, 0, 0, 1, 1, {{{-kMaxPixelIndex, kMaxPixelIndex + 1}}}).voxel_count(), whole);
}

// Both dimensions hold the same bound: an index at it is stored, one past it refused.
TEST(CoreRuns, BothDimensionsRefuseIndicesPastTheBound) {
  EXPECT_EQ(DigitalSet::from_rows(1.0, 0, {{{kMaxPixelIndex, kMaxPixelIndex + 1}}}).pixel_count(), 1);
  EXPECT_EQ(DigitalSet::from_rows(1.0, -kMaxPixelIndex, {{{-kMaxPixelIndex, -kMaxPixelIndex + 1}}}).pixel_count(), 1);
  EXPECT_THROW(DigitalSet::from_rows(1.0, 0, {{{kMaxPixelIndex + 1, kMaxPixelIndex + 2}}}), Error);
  EXPECT_THROW(DigitalSet::from_rows(1.0, kMaxPixelIndex + 1, {{{0, 1}}}), Error);
  EXPECT_EQ(surface::VoxelSet::from_rows(1.0, 0, 0, 1, 1, {{{-kMaxPixelIndex, -kMaxPixelIndex + 2}}}).voxel_count(), 2);
  EXPECT_EQ(surface::VoxelSet::from_rows(1.0, 0, 0, 1, 1, {{{kMaxPixelIndex, kMaxPixelIndex + 1}}}).voxel_count(), 1);
  EXPECT_THROW(surface::VoxelSet::from_rows(1.0, 0, 0, 1, 1, {{{kMaxPixelIndex + 1, kMaxPixelIndex + 2}}}), Error);
  EXPECT_THROW(surface::VoxelSet::from_rows(1.0, -kMaxPixelIndex - 1, 0, 1, 1, {{{0, 1}}}), Error);
}

TEST(CoreRuns, NormalizeMergesOverlappingAndTouchingRunsAndDropsEmptyOnes) {
  std::vector<digilap::Run> runs = {{5, 7}, {0, 2}, {2, 3}, {6, 9}, {4, 4}, {12, 11}, {10, 11}};
  detail::normalize_runs(runs);
  ASSERT_EQ(runs.size(), 3u);
  // [0,2) and [2,3) touch, [5,7) and [6,9) overlap, [4,4) and [12,11) are empty.
  const std::vector<std::pair<int, int>> expected = {{0, 3}, {5, 9}, {10, 11}};
  for (std::size_t r = 0; r < 3; ++r) {
    EXPECT_EQ(runs[r].begin, expected[r].first) << r;
    EXPECT_EQ(runs[r].end, expected[r].second) << r;
  }
  EXPECT_EQ(detail::run_total(runs), 3 + 4 + 1);
  // Membership is half-open at both ends of each run.
  const digilap::Run* b = runs.data();
  const digilap::Run* e = b + runs.size();
  for (std::int32_t i : {0, 2, 5, 8, 10}) EXPECT_TRUE(detail::in_runs(b, e, i)) << i;
  for (std::int32_t i : {-1, 3, 4, 9, 11}) EXPECT_FALSE(detail::in_runs(b, e, i)) << i;
  EXPECT_FALSE(detail::in_runs(b, b, 0));  // an empty row
}
