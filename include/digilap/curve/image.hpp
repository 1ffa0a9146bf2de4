// digilap — binary images in: Netpbm (PBM/PGM, ASCII and binary, 8 and 16 bit) and PNG.
//
// Frame: image column c, row r (row 0 at the top, as stored) becomes pixel (i, j) =
// (c, height - 1 - r) of the grid hZ^2, so the picture is upright in a y-up frame and pixel
// centres are at (c h, (height - 1 - r) h). The default h = 1 / max(width, height) makes the
// image span the unit square.
#pragma once

#include "digilap/curve/contour.hpp"
#include "digilap/curve/digitization.hpp"

#include <cstdint>
#include <string>
#include <vector>

namespace digilap {
inline namespace curve {

/// A grey image, row-major from the top row, values in [0, maxval].
struct GrayImage {
  int width = 0, height = 0;
  int maxval = 255;
  std::vector<std::uint16_t> pixels;
  std::uint16_t at(int column, int row) const { return pixels[static_cast<std::size_t>(row) * width + column]; }
};

struct ImageLimits {
  /// Largest accepted width * height (decoded grey pixels take 2 bytes each).
  std::int64_t max_pixels = 400'000'000;
};

/// Reads a PBM (P1, P4), PGM (P2, P5, maxval up to 65535) or PNG file, chosen by its magic
/// bytes. PNG colours become luminance, transparency is composited over white. PBM's black
/// (1) becomes grey 0, white becomes 1 (maxval 1). Throws digilap::Error with the file name and
/// the reason for: a missing or unreadable file, an empty or truncated file, an unknown
/// magic, a width or height that is 0, negative, or too large (width * height above the limit),
/// a maxval of 0 or above 65535, a value above maxval.
GrayImage read_image(const std::string& path, const ImageLimits& limits = {});
/// The same from bytes in memory (`name` is used in messages).
GrayImage decode_image(const std::uint8_t* data, std::size_t size, const std::string& name = "image",
                       const ImageLimits& limits = {});

struct BinarizeOptions {
  /// Grid step; 0 means 1 / max(width, height) (the image spans the unit square).
  double h = 0.0;
  /// Foreground: value < threshold * maxval (dark objects on a light background) ...
  double threshold = 0.5;
  /// ... or value >= threshold * maxval with invert (light objects on a dark background).
  bool invert = false;
};

/// The foreground pixels as a digital set. Objects touching the border are fine: the set lives
/// in the unbounded plane, whose outside is background (no padding needed). Throws
/// digilap::Error for h < 0 or not finite, or a threshold outside (0, 1].
DigitalSet binarize(const GrayImage& image, const BinarizeOptions& options = {});

/// Keeping some contours only.
struct ContourFilter {
  std::size_t min_linels = 0;  ///< drop contours with fewer linels than this
  bool largest_only = false;   ///< keep only the contour with the most linels
};

/// The contours that pass the filter (in their original order) and how many were dropped.
struct FilteredContours {
  ContourSet contours;
  std::size_t dropped = 0;
};
FilteredContours filter_contours(const ContourSet& contours, const ContourFilter& filter);

}  // namespace curve
}  // namespace digilap
