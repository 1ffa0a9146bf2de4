// The kernel's weights w = scale exp(-d2 / 4t) (lib/core/gaussian_kernel.hpp), computed by the
// library's own vector exp: against long double's expl over the whole range the kernel can see,
// exact where exp is exact, 0 where it leaves the normal doubles, and the same bits from the
// assembled operators' entry point and the surface products' one.
#include "core/gaussian_kernel.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <vector>

using digilap::gaussian_weights;
using digilap::gaussian_weights_room;
using digilap::gaussian_weights_wide;

namespace {
// Aligned to 64 bytes with gaussian_weights_wide's room.
struct AlignedValues {
  explicit AlignedValues(const std::vector<double>& v)
      : size(static_cast<Eigen::Index>(v.size())),
        data(static_cast<double*>(std::aligned_alloc(64, static_cast<std::size_t>(gaussian_weights_room(size)) * sizeof(double)))) {
    std::copy(v.begin(), v.end(), data);
  }
  ~AlignedValues() { std::free(data); }
  AlignedValues(const AlignedValues&) = delete;
  AlignedValues& operator=(const AlignedValues&) = delete;
  Eigen::Index size;
  double* data;
};

// Squared distances whose arguments -d2 inv_4t cover [-800, 0]: dense near 0 (the kernel's
// body), then out past the underflow.
std::vector<double> squared_distances(double inv_4t) {
  std::vector<double> d2;
  for (int k = 0; k <= 20000; ++k) d2.push_back(std::pow(k / 20000.0, 2) * 800.0 / inv_4t);
  d2.push_back(0.0);
  return d2;
}

// |got - exact| in units of the last place of exact (a normal double).
double ulps(double got, long double exact) {
  const double unit = std::numeric_limits<double>::epsilon() * std::pow(2.0, std::ilogb(static_cast<double>(exact)));
  return static_cast<double>(std::fabs(static_cast<long double>(got) - exact) / unit);
}
}  // namespace

// Cody and Waite's reduction and a degree-13 Taylor polynomial: measured within 1.4 ulp of the
// exact value of the rounded argument, the scale's rounding included (1.0-1.4 ulp for the SSE2
// build too, whose Horner steps round twice); 2.5 ulp leaves room for that and fails for
// glibc's libmvec exp, which the library used before (3.5 ulp on these values).
TEST(GaussianKernel, WithinTwoAndAHalfUlpOfExpWhereExpIsNormal) {
  for (const double inv_4t : {0.25, 53.1, 1.0 / (4 * 0.004705)}) {
    for (const double scale : {1.0, 3.7e-3}) {
      const std::vector<double> d2 = squared_distances(inv_4t);
      std::vector<double> w = d2;
      gaussian_weights(w.data(), static_cast<Eigen::Index>(w.size()), inv_4t, scale);
      double worst = 0;
      std::size_t checked = 0;
      for (std::size_t k = 0; k < d2.size(); ++k) {
        const double x = -d2[k] * inv_4t;  // the argument as the library rounds it
        const long double exact = static_cast<long double>(scale) * std::exp(static_cast<long double>(x));
        if (x < -708 || exact < std::numeric_limits<double>::min()) continue;  // 0 or subnormal
        worst = std::max(worst, ulps(w[k], exact));
        ++checked;
      }
      EXPECT_GT(checked, 18000u);
      EXPECT_LE(worst, 2.5) << "inv_4t " << inv_4t << ", scale " << scale;
    }
  }
}

TEST(GaussianKernel, ExactAtZeroAndZeroPastTheNormalRange) {
  std::vector<double> d2 = {0.0, 708.0 * 4, 708.5 * 4, 750.0 * 4, 1e6, 1e300};
  gaussian_weights(d2.data(), static_cast<Eigen::Index>(d2.size()), 0.25, 2.5);
  EXPECT_EQ(d2[0], 2.5);  // exp(0) = 1 exactly, times the scale
  EXPECT_GT(d2[1], 0.0);  // exp(-708) is still a normal double
  EXPECT_NEAR(d2[1] / (2.5 * std::exp(-708.0)), 1.0, 1e-15);
  for (std::size_t k = 2; k < d2.size(); ++k) EXPECT_EQ(d2[k], 0.0) << k;
  // +infinity (the surface products' pairs left out, surfel_grid.hpp) gives +0, through both
  // entry points.
  std::vector<double> out = {std::numeric_limits<double>::infinity(), 0.0};
  gaussian_weights(out.data(), 2, 53.1, 0.37);
  EXPECT_EQ(out[0], 0.0);
  EXPECT_FALSE(std::signbit(out[0]));
  EXPECT_EQ(out[1], 0.37);
  AlignedValues wide(std::vector<double>(70, std::numeric_limits<double>::infinity()));
  gaussian_weights_wide(wide.data, wide.size, 53.1, 0.37);
  for (Eigen::Index k = 0; k < wide.size; ++k) EXPECT_EQ(wide.data[k], 0.0) << k;
}

// A pair's weight is the same in every operator (the assembled rows take gaussian_weights, the
// surface products gaussian_weights_wide): counts that are not multiples of the chunk, too.
TEST(GaussianKernel, BothEntryPointsGiveTheSameBits) {
  const double inv_4t = 1.0 / (4 * 0.004705);
  std::vector<double> all = squared_distances(inv_4t);
  for (const std::size_t count : {std::size_t{1}, std::size_t{63}, std::size_t{64}, std::size_t{65}, all.size()}) {
    const std::vector<double> d2(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(count));
    std::vector<double> assembled = d2;
    gaussian_weights(assembled.data(), static_cast<Eigen::Index>(count), inv_4t, 0.37);
    AlignedValues wide(d2);
    gaussian_weights_wide(wide.data, wide.size, inv_4t, 0.37);
    for (std::size_t k = 0; k < count; ++k) ASSERT_EQ(assembled[k], wide.data[k]) << "count " << count << ", value " << k;
  }
}
