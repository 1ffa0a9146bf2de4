// Images in: Netpbm and PNG decoding, frame, binarization, contour filtering, the horse.
#include "digilap/core/error.hpp"
#include "digilap/curve/heat_laplacian.hpp"
#include "digilap/curve/image.hpp"
#include "digilap/curve/spectrum.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb/stb_image_write.h>

using namespace digilap;

namespace {

std::vector<std::uint8_t> bytes(const std::string& s) { return {s.begin(), s.end()}; }
GrayImage decode(const std::string& s) {
  const auto b = bytes(s);
  return decode_image(b.data(), b.size(), "test");
}
// A 5 x 3 picture (top row first): an L of dark pixels.
//   X . . . .
//   X . . . .
//   X X X . .
const std::vector<int> kDark = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1, 1, 0, 0};

}  // namespace

TEST(Image, AllNetpbmFlavoursDecodeToTheSamePicture) {
  const GrayImage p1 = decode("P1\n# a comment\n5 3\n1 0 0 0 0\n1 0 0 0 0\n11100\n");
  const GrayImage p2 = decode("P2 5 3 # width height\n255\n0 255 255 255 255\n0 255 255 255 255\n0 0 0 255 255\n");
  std::string p4 = "P4\n5 3\n";
  for (int r = 0; r < 3; ++r) {
    unsigned char byte = 0;
    for (int c = 0; c < 5; ++c) byte |= kDark[r * 5 + c] << (7 - c);
    p4 += static_cast<char>(byte);
  }
  std::string p5_16 = "P5\n5 3\n65535\n";
  for (int v : kDark) p5_16 += v ? std::string(2, '\0') : std::string("\xff\xff", 2);
  for (const GrayImage* im : {&p1, &p2}) ASSERT_EQ(im->pixels.size(), 15u);
  for (const GrayImage& im : {p1, p2, decode(p4), decode(p5_16)}) {
    ASSERT_EQ(im.width, 5);
    ASSERT_EQ(im.height, 3);
    for (int k = 0; k < 15; ++k) EXPECT_EQ(im.pixels[k] < 0.5 * im.maxval, kDark[k] == 1) << k;
  }
  EXPECT_EQ(decode(p5_16).maxval, 65535);
}

TEST(Image, PngGreyAndRgbaWithTransparency) {
  const auto dir = std::filesystem::temp_directory_path() / "digilap_test_image";
  std::filesystem::create_directories(dir);
  // RGBA: dark opaque pixels where kDark, fully transparent black elsewhere (white when composited).
  std::vector<unsigned char> rgba(15 * 4, 0);
  for (int k = 0; k < 15; ++k) rgba[4 * k + 3] = kDark[k] ? 255 : 0;
  const std::string path = (dir / "l.png").string();
  ASSERT_TRUE(stbi_write_png(path.c_str(), 5, 3, 4, rgba.data(), 5 * 4));
  const GrayImage im = read_image(path);
  ASSERT_EQ(im.width, 5);
  for (int k = 0; k < 15; ++k) EXPECT_EQ(im.pixels[k], kDark[k] ? 0 : 255) << k;
}

TEST(Image, PngWhoseChunkRunsPastTheFileIsRefusedBeforeDecoding) {
  // Fuzzing found a 129-byte PNG declaring a 1.15 GB IDAT chunk: stb allocated it before noticing.
  // It must be refused by the chunk walk, naming the chunk; so must a file cut before IEND.
  const auto dir = std::filesystem::temp_directory_path() / "digilap_test_image";
  std::filesystem::create_directories(dir);
  std::vector<unsigned char> grey(15);
  for (int k = 0; k < 15; ++k) grey[k] = kDark[k] ? 0 : 255;
  const std::string path = (dir / "cut.png").string();
  ASSERT_TRUE(stbi_write_png(path.c_str(), 5, 3, 1, grey.data(), 5));
  std::ifstream in(path, std::ios::binary);
  const std::string whole((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto as_bytes = [](const std::string& s) { return reinterpret_cast<const std::uint8_t*>(s.data()); };
  EXPECT_EQ(decode_image(as_bytes(whole), whole.size(), "whole").width, 5);
  const auto message_of = [&](const std::string& bytes) {
    try {
      decode_image(as_bytes(bytes), bytes.size(), "f");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("decoded");
  };
  EXPECT_NE(message_of(whole.substr(0, whole.size() - 12)).find("no IEND"), std::string::npos);  // IEND cut off
  EXPECT_NE(message_of(whole.substr(0, whole.size() - 20)).find("runs past the end"), std::string::npos);  // inside IDAT
  const std::string fuzz_found = std::string(DIGILAP_FUZZ_CORPUS) + "/regression_png_chunk_overruns_file.png";
  try {
    read_image(fuzz_found);
    ADD_FAILURE() << "the overrunning chunk was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("1152253977 bytes"), std::string::npos) << e.what();
  }
}

TEST(Image, FrameIsYUpAndTheImageSpansTheUnitSquare) {
  const GrayImage im = decode("P1 5 3 1 0 0 0 0 1 0 0 0 0 1 1 1 0 0");
  const DigitalSet set = binarize(im);
  EXPECT_DOUBLE_EQ(set.h(), 0.2);  // 1 / max(5, 3)
  EXPECT_EQ(set.pixel_count(), 5);
  EXPECT_TRUE(set.contains(0, 2));   // top-left of the picture: column 0, row 0 -> j = 2
  EXPECT_TRUE(set.contains(2, 0));   // bottom row, third column
  EXPECT_FALSE(set.contains(2, 2));
  const DigitalSet inverted = binarize(im, {0.1, 0.5, true});
  EXPECT_EQ(inverted.pixel_count(), 10);
  EXPECT_DOUBLE_EQ(inverted.h(), 0.1);
  // Objects touching the border need no padding: one closed contour around the L.
  const ContourSet cs = track_contours(set);
  ASSERT_EQ(cs.contours.size(), 1u);
  EXPECT_EQ(cs.contours[0].twice_signed_area(), 10);
}

TEST(Image, FilterDropsShortContoursAndKeepsTheLargest) {
  // A 6 x 6 block, a single pixel, and a 2-pixel bar.
  std::string pgm = "P2 12 8 1\n";
  for (int r = 0; r < 8; ++r)
    for (int c = 0; c < 12; ++c) {
      const bool dark = (r >= 1 && r <= 6 && c >= 1 && c <= 6) || (r == 1 && c == 9) || (r == 5 && (c == 9 || c == 10));
      pgm += dark ? "0 " : "1 ";
    }
  const ContourSet cs = track_contours(binarize(decode(pgm)));
  ASSERT_EQ(cs.contours.size(), 3u);
  const FilteredContours a = filter_contours(cs, {5, false});
  EXPECT_EQ(a.dropped, 1u);  // the single pixel (4 linels)
  EXPECT_EQ(a.contours.contours.size(), 2u);
  const FilteredContours b = filter_contours(cs, {0, true});
  EXPECT_EQ(b.dropped, 2u);
  ASSERT_EQ(b.contours.contours.size(), 1u);
  EXPECT_EQ(b.contours.contours[0].size(), 24u);
}

TEST(Image, HorseSpectrumRatiosAreSquares) {
  // A real segmented image from a Debian package (scikit-image's horse). scripts/test.sh
  // extracts it into build/test-data when the package is not installed.
  std::string path;
  const char* env = std::getenv("DIGILAP_HORSE");
  for (const char* candidate : std::initializer_list<const char*>{env, "/usr/lib/python3/dist-packages/skimage/data/horse.png",
                                DIGILAP_TEST_DATA "/horse.png"})
    if (candidate && std::filesystem::exists(candidate)) { path = candidate; break; }
  if (path.empty()) GTEST_SKIP() << "horse.png not found (python3-skimage data); run scripts/fetch_test_data.sh";
  const DigitalSet set = binarize(read_image(path));
  const FilteredContours main = filter_contours(track_contours(set), {0, true});
  const ContourOperator op = heat_laplacian(main.contours, measures(main.contours, ii_normals(set, main.contours)));
  const Spectrum s = smallest_eigenpairs(op, {11});
  // SPEC §5: on any simple closed contour, lambda_{2m-1} ~ lambda_{2m} ~ m^2 lambda_1. Issue
  // 14 asks 1% at the defaults (the heat kernel's bias omega^2 t / 2 is below 1e-4 here; the
  // former t gave 24.75 for m = 5, 1% low).
  for (int m = 1; m <= 5; ++m) {
    EXPECT_NEAR(s.eigenvalues[2 * m] / s.eigenvalues[1], m * m, 0.01 * m * m) << "m = " << m;
    EXPECT_NEAR(s.eigenvalues[2 * m - 1] / s.eigenvalues[1], m * m, 0.01 * m * m) << "m = " << m;
  }
}

TEST(Image, EveryFuzzSeedDecodesOrIsRefusedClearly) {
  // The committed seeds include inputs that once tripped a sanitizer (regression_*): each must
  // give an image whose contours enclose exactly its pixels, or a digilap::Error.
  int decoded = 0, refused = 0;
  for (const auto& entry : std::filesystem::directory_iterator(DIGILAP_FUZZ_CORPUS)) {
    try {
      const DigitalSet set = binarize(read_image(entry.path().string()));
      std::int64_t twice_area = 0;
      for (const auto& c : track_contours(set).contours) twice_area += c.twice_signed_area();
      EXPECT_EQ(twice_area, 2 * set.pixel_count()) << entry.path();
      ++decoded;
    } catch (const Error&) {
      ++refused;
    }
  }
  EXPECT_GE(decoded, 6);
  EXPECT_GE(decoded + refused, 8);
}

TEST(Image, PngThatStbRejectsWithoutAReasonIsAnError) {
  // Found by fuzz_image: stb failed on this PNG with a null reason, and the message was built
  // from it (a crash). It must be a digilap::Error naming the file.
  const unsigned char png[] = {137, 80, 78, 71, 13, 10, 26, 10, 0, 0, 0, 13, 73, 72, 68, 82, 0, 0, 0, 8, 0, 0, 0, 8, 8, 0, 0, 0, 0, 225, 100, 225, 87, 0, 0, 0, 25, 73, 68, 65, 84, 120, 156, 167, 7, 240, 250, 12, 64, 4, 4, 32, 6, 3, 24, 224, 103, 192, 21, 67, 1, 0, 124, 4, 31, 225, 142, 128, 54, 61, 0, 0, 0, 0, 73, 69, 78, 68, 174, 66, 96, 130};
  try {
    decode_image(png, sizeof(png), "fuzzed.png");
    FAIL() << "decoded";
  } catch (const digilap::Error& e) {
    EXPECT_NE(std::string(e.what()).find("fuzzed.png"), std::string::npos) << e.what();
  }
}
