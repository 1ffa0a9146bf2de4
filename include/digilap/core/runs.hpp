// digilap — runs of consecutive pixels or voxels along a grid row (core): how digital sets
// of every dimension store themselves (curve/digitization.hpp, surface/digitization.hpp), so that
// memory grows with the boundary, not with the area or volume.
#pragma once

#include <cstdint>

namespace digilap {

/// Pixel and voxel indices lie in [-kMaxPixelIndex, kMaxPixelIndex]: every index, its
/// neighbours and a run's end fit in 32 bits with room to spare. Lengths and differences of
/// indices (up to 2^31 + 1) need 64 bits: the library computes them so.
constexpr std::int32_t kMaxPixelIndex = 1 << 30;

/// Pixels (voxels) begin, begin + 1, ..., end - 1 of one row (half-open).
struct Run {
  std::int32_t begin;
  std::int32_t end;
};

}  // namespace digilap
