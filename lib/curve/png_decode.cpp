#include "png_decode.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

// PNG through stb_image (Debian's libstb-dev), compiled here as its single-file implementation,
// static and PNG only: the smallest decoder surface to expose to untrusted files. This file is
// built with -fno-sanitize=nonnull-attribute: stb copies zero bytes from a null pointer on
// empty IDAT chunks (memcpy(NULL, p, 0), harmless, but undefined to UBSan; found by fuzzing).
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#define STBI_NO_STDIO
#if defined(__GNUC__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#endif
#include <stb/stb_image.h>
#if defined(__GNUC__)
#pragma GCC diagnostic pop
#endif

namespace digilap {
inline namespace curve {
namespace detail {

namespace {

std::uint32_t read_big_endian_u32(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
}

// stb trusts each chunk's declared length and grows its IDAT buffer to it before checking that
// the bytes exist, so a 100-byte file claiming a 1 GB chunk makes it allocate 1 GB (found by
// fuzzing). Walk the chunk list first: every chunk must fit inside the file, up to IEND.
void check_png_chunks_fit(const std::uint8_t* data, std::size_t size, const std::string& name) {
  constexpr std::size_t kSignature = 8, kChunkOverhead = 12;  // length, type, CRC
  std::size_t offset = kSignature;
  while (true) {
    if (size - offset < kChunkOverhead) throw Error(name + ": not a readable PNG (truncated: no IEND chunk)");
    const std::uint32_t length = read_big_endian_u32(data + offset);
    if (length > size - offset - kChunkOverhead)
      throw Error(name + ": not a readable PNG (a chunk of " + std::to_string(length) + " bytes at offset " + std::to_string(offset) +
                  " runs past the end of the " + std::to_string(size) + "-byte file)");
    const bool is_end = std::equal(data + offset + 4, data + offset + 8, "IEND");
    offset += kChunkOverhead + length;
    if (is_end) return;
  }
}

}  // namespace

// stb's reason for a failure, which can be null (a decoder that failed without saying why: a
// fuzzed PNG made std::string + null crash).
static std::string failure_reason() {
  const char* reason = stbi_failure_reason();
  return reason ? reason : "no reason given";
}

GrayImage decode_png(const std::uint8_t* data, std::size_t size, const std::string& name, const ImageLimits& limits) {
  if (size > static_cast<std::size_t>(INT32_MAX)) throw Error(name + ": file too large");
  int w = 0, h = 0, channels = 0;
  const auto len = static_cast<int>(size);
  if (size >= 8) check_png_chunks_fit(data, size, name);  // shorter: stbi_info refuses it below
  if (!stbi_info_from_memory(data, len, &w, &h, &channels)) throw Error(name + ": " + "not a readable PNG (" + failure_reason() + ")");
  check_image_size(w, h, name, limits);  // before decoding: the decoder allocates w * h * channels
  const bool sixteen = stbi_is_16_bit_from_memory(data, len);
  GrayImage image;
  image.width = w;
  image.height = h;
  image.maxval = sixteen ? 65535 : 255;
  image.pixels.resize(static_cast<std::size_t>(w) * h);
  auto convert = [&](auto* px) {
    if (!px) throw Error(name + ": " + "cannot decode the PNG (" + failure_reason() + ")");
    const double top = image.maxval;
    for (std::size_t k = 0; k < image.pixels.size(); ++k) {
      const auto* p = px + k * channels;
      double grey = channels >= 3 ? 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2] : p[0];
      const bool alpha = channels == 2 || channels == 4;
      if (alpha) {
        const double a = p[channels - 1] / top;
        grey = a * grey + (1 - a) * top;  // transparency composited over white
      }
      image.pixels[k] = static_cast<std::uint16_t>(std::lround(std::clamp(grey, 0.0, top)));
    }
    stbi_image_free(px);
  };
  if (sixteen) convert(stbi_load_16_from_memory(data, len, &w, &h, &channels, 0));
  else convert(stbi_load_from_memory(data, len, &w, &h, &channels, 0));
  return image;
}

}  // namespace detail
}  // namespace curve
}  // namespace digilap
