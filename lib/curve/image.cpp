#include "digilap/curve/image.hpp"

#include "digilap/core/error.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>

#include "png_decode.hpp"

namespace digilap {
inline namespace curve {

namespace {

[[noreturn]] void fail(const std::string& name, const std::string& why) { throw Error(name + ": " + why); }

}  // namespace

namespace detail {
void check_image_size(long long width, long long height, const std::string& name, const ImageLimits& limits) {
  if (width <= 0 || height <= 0)
    fail(name, "width and height must be > 0, got " + std::to_string(width) + " x " + std::to_string(height));
  if (width > limits.max_pixels || height > limits.max_pixels || width * height > limits.max_pixels)
    fail(name, "image of " + std::to_string(width) + " x " + std::to_string(height) + " pixels is above the limit of " +
                   std::to_string(limits.max_pixels) + " pixels");
}
}  // namespace detail

namespace {

// Netpbm is a few lines of grammar; written here because stb reads neither ASCII Netpbm nor PBM.
class NetpbmReader {
public:
  NetpbmReader(const std::uint8_t* data, std::size_t size, std::string name) : p_(data), end_(data + size), name_(std::move(name)) {}

  GrayImage read(const ImageLimits& limits) {
    const char kind = static_cast<char>(p_[1]);
    p_ += 2;
    GrayImage image;
    const long long width = number("width"), height = number("height");
    detail::check_image_size(width, height, name_, limits);
    image.width = static_cast<int>(width);
    image.height = static_cast<int>(height);
    if (kind == '2' || kind == '5') {
      const long long maxval = number("maxval");
      if (maxval < 1 || maxval > 65535) fail(name_, "maxval must be in [1, 65535], got " + std::to_string(maxval));
      image.maxval = static_cast<int>(maxval);
    } else {
      image.maxval = 1;
    }
    const std::size_t count = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    image.pixels.resize(count);
    if (kind == '1' || kind == '2') {
      for (std::size_t k = 0; k < count; ++k) image.pixels[k] = kind == '1' ? bit_ascii(k, count) : sample_ascii(image.maxval, k, count);
    } else {
      // Exactly one whitespace byte separates the header from the raster.
      if (p_ >= end_ || !std::isspace(*p_)) fail(name_, "truncated: no raster after the header");
      ++p_;
      if (kind == '4') {
        const std::size_t row_bytes = (static_cast<std::size_t>(width) + 7) / 8;
        need(row_bytes * static_cast<std::size_t>(height), "bytes of raster");
        for (int r = 0; r < image.height; ++r)
          for (int c = 0; c < image.width; ++c)
            image.pixels[static_cast<std::size_t>(r) * width + c] = ((p_[r * row_bytes + c / 8] >> (7 - c % 8)) & 1) ? 0 : 1;
      } else {
        const std::size_t bytes = image.maxval < 256 ? 1 : 2;
        need(count * bytes, "bytes of raster");
        for (std::size_t k = 0; k < count; ++k) {
          const unsigned v = bytes == 1 ? p_[k] : (static_cast<unsigned>(p_[2 * k]) << 8) | p_[2 * k + 1];
          if (v > static_cast<unsigned>(image.maxval))
            fail(name_, "pixel value " + std::to_string(v) + " is above maxval " + std::to_string(image.maxval));
          image.pixels[k] = static_cast<std::uint16_t>(v);
        }
      }
    }
    return image;
  }

private:
  void skip_space_and_comments() {
    while (p_ < end_) {
      if (std::isspace(*p_)) ++p_;
      else if (*p_ == '#') while (p_ < end_ && *p_ != '\n') ++p_;
      else break;
    }
  }
  long long number(const char* what) {
    skip_space_and_comments();
    if (p_ >= end_) fail(name_, std::string("truncated: no ") + what + " in the header");
    if (*p_ == '-') fail(name_, std::string(what) + " is negative");
    if (!std::isdigit(*p_)) fail(name_, std::string("expected a number for the ") + what);
    long long v = 0;
    while (p_ < end_ && std::isdigit(*p_)) {
      v = v * 10 + (*p_++ - '0');
      if (v > 1'000'000'000'000LL) fail(name_, std::string(what) + " is too large");
    }
    return v;
  }
  std::uint16_t bit_ascii(std::size_t k, std::size_t count) {
    skip_space_and_comments();
    if (p_ >= end_) truncated(k, count);
    const std::uint8_t c = *p_++;
    if (c != '0' && c != '1') fail(name_, "PBM pixels must be 0 or 1");
    return c == '1' ? 0 : 1;  // PBM: 1 is black
  }
  std::uint16_t sample_ascii(int maxval, std::size_t k, std::size_t count) {
    skip_space_and_comments();
    if (p_ >= end_) truncated(k, count);
    const long long v = number("pixel value");
    if (v > maxval) fail(name_, "pixel value " + std::to_string(v) + " is above maxval " + std::to_string(maxval));
    return static_cast<std::uint16_t>(v);
  }
  [[noreturn]] void truncated(std::size_t k, std::size_t count) {
    fail(name_, "truncated: " + std::to_string(k) + " of " + std::to_string(count) + " pixels");
  }
  void need(std::size_t bytes, const char* what) {
    if (static_cast<std::size_t>(end_ - p_) < bytes)
      fail(name_, "truncated: " + std::to_string(end_ - p_) + " of " + std::to_string(bytes) + " " + what);
  }

  const std::uint8_t* p_;
  const std::uint8_t* end_;
  std::string name_;
};

}  // namespace

GrayImage decode_image(const std::uint8_t* data, std::size_t size, const std::string& name, const ImageLimits& limits) {
  if (size == 0) fail(name, "the file is empty");
  if (size >= 2 && data[0] == 'P' && (data[1] == '1' || data[1] == '2' || data[1] == '4' || data[1] == '5'))
    return NetpbmReader(data, size, name).read(limits);
  static const std::uint8_t png_magic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (size >= 8 && std::equal(png_magic, png_magic + 8, data)) return detail::decode_png(data, size, name, limits);
  fail(name, "unknown format (expected a PBM P1/P4, PGM P2/P5 or PNG file)");
}

GrayImage read_image(const std::string& path, const ImageLimits& limits) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open the file (does it exist and is it readable?)");
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return decode_image(bytes.data(), bytes.size(), path, limits);
}

DigitalSet binarize(const GrayImage& image, const BinarizeOptions& o) {
  if (!(o.h >= 0) || !std::isfinite(o.h)) {
    std::ostringstream msg;
    msg << "binarize: h must be > 0 and finite (or 0 for 1 / max(width, height)), got " << o.h;
    throw Error(msg.str());
  }
  if (!(o.threshold > 0 && o.threshold <= 1)) {
    std::ostringstream msg;
    msg << "binarize: the threshold is a fraction of maxval in (0, 1], got " << o.threshold;
    throw Error(msg.str());
  }
  if (image.width <= 0 || image.height <= 0 || image.pixels.size() != static_cast<std::size_t>(image.width) * image.height)
    throw Error("binarize: the image is empty or inconsistent");
  const double h = o.h > 0 ? o.h : 1.0 / std::max(image.width, image.height);
  const double cut = o.threshold * image.maxval;
  std::vector<std::vector<Run>> rows(static_cast<std::size_t>(image.height));
  for (int r = 0; r < image.height; ++r) {
    auto& runs = rows[static_cast<std::size_t>(image.height - 1 - r)];  // y up: the top row is the last
    for (int c = 0; c < image.width;) {
      auto fg = [&](int col) { return (image.at(col, r) < cut) != o.invert; };
      if (!fg(c)) { ++c; continue; }
      int e = c;
      while (e < image.width && fg(e)) ++e;
      runs.push_back({c, e});
      c = e;
    }
  }
  return DigitalSet::from_rows(h, 0, std::move(rows));
}

FilteredContours filter_contours(const ContourSet& contours, const ContourFilter& filter) {
  FilteredContours out;
  out.contours.h = contours.h;
  std::size_t largest = 0;
  for (std::size_t c = 1; c < contours.contours.size(); ++c)
    if (contours.contours[c].size() > contours.contours[largest].size()) largest = c;
  for (std::size_t c = 0; c < contours.contours.size(); ++c) {
    const bool keep = contours.contours[c].size() >= filter.min_linels && (!filter.largest_only || c == largest);
    if (keep) out.contours.contours.push_back(contours.contours[c]);
    else ++out.dropped;
  }
  return out;
}

}  // namespace curve
}  // namespace digilap
