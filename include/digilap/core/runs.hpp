// digilap — runs of consecutive pixels or voxels along a grid row (core): how digital sets
// of every dimension store themselves (curve/digitization.hpp, surface/digitization.hpp), so that
// memory grows with the boundary, not with the area or volume.
#pragma once

#include <cstdint>

namespace digilap {

/// Pixel and voxel indices lie in [-kMaxPixelIndex, kMaxPixelIndex]: the boundaries need
/// room for the neighbours of every pixel, and differences of indices must fit in 32 bits.
constexpr std::int32_t kMaxPixelIndex = 1 << 30;

/// Pixels (voxels) begin, begin + 1, ..., end - 1 of one row (half-open).
struct Run {
  std::int32_t begin;
  std::int32_t end;
};

}  // namespace digilap
