// Internal: PNG decoding (stb_image), kept in its own file; see png_decode.cpp.
#pragma once

#include "digilap/curve/image.hpp"

#include <cstddef>
#include <cstdint>
#include <string>

namespace digilap {
inline namespace curve {
namespace detail {

/// Throws digilap::Error unless 0 < width, height and width * height <= limits.max_pixels.
void check_image_size(long long width, long long height, const std::string& name, const ImageLimits& limits);

/// A PNG in memory as a grey image (luminance, transparency over white).
GrayImage decode_png(const std::uint8_t* data, std::size_t size, const std::string& name, const ImageLimits& limits);

}  // namespace detail
}  // namespace curve
}  // namespace digilap
