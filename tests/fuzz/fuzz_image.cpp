// libFuzzer target: image reader -> binarization -> contour tracking -> II normals -> measures.
// Any input must give a result or a digilap::Error; anything else (a crash, a sanitizer
// report, another exception) is a bug. Built and run by scripts/fuzz.sh.
#include "digilap/core/error.hpp"
#include "digilap/curve/image.hpp"
#include "digilap/curve/measures.hpp"

#include <cstddef>
#include <cstdint>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    digilap::ImageLimits limits;
    limits.max_pixels = 1 << 18;  // keep each run fast: 512 x 512 at most
    const digilap::GrayImage image = digilap::decode_image(data, size, "fuzz", limits);
    digilap::BinarizeOptions o;
    o.threshold = 0.5;
    o.invert = size % 2 == 1;  // both polarities, chosen by the input
    const digilap::DigitalSet set = digilap::binarize(image, o);
    const digilap::ContourSet contours = digilap::track_contours(set);
    // Every linel in exactly one contour: the pointel polygons enclose exactly the pixels.
    std::int64_t twice_area = 0;
    for (const auto& c : contours.contours) twice_area += c.twice_signed_area();
    if (twice_area != 2 * set.pixel_count()) __builtin_trap();
    if (!contours.contours.empty()) {
      const auto normals = digilap::ii_normals(set, contours, {0.5});
      const digilap::Measures mu = digilap::measures(contours, normals);
      if (!(mu.total_length() >= 0)) __builtin_trap();
    }
  } catch (const digilap::Error&) {
    // A clear refusal is a correct answer.
  }
  return 0;
}
