// Internal: exact integer moments of the pixels of a digital set inside a disk, in O(R/h) per
// disk through the runs of its rows. Shared by the II normals and the II curvature of the
// length scale.
#pragma once

#include "digilap/curve/digitization.hpp"

#include <cstdint>
#include <vector>

namespace digilap::detail {

// Exact integer moments of the pixel centres in a disk, in pixel units relative to a nearby
// pixel (so that the sums stay small and exact).
struct Moments {
  std::int64_t n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
};

/// Half-widths of the disk's chords, in doubled pixel units: chord[d] = floor(sqrt((2 rho)^2 -
/// d^2)) for the doubled vertical offsets d = 0 .. floor(2 rho) (rho: the radius in pixels).
std::vector<std::int64_t> chord_table(double rho);

/// Moments of the set's pixels in the disk of the chord table centred at (X/2, Y/2) pixels
/// (doubled coordinates, so that pointels and linel midpoints are integers).
Moments disk_moments(const DigitalSet& set, std::int64_t X, std::int64_t Y, const std::vector<std::int64_t>& chord);

}  // namespace digilap::detail
