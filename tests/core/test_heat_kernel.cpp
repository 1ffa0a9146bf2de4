// core/heat_kernel.hpp: the default heat time t = c_t h^(2/3) l^(4/3) of every dimension (SPEC
// §4, §7), which l it takes, and its refusals.
#include "digilap/core/heat_kernel.hpp"
#include "digilap/core/error.hpp"
#include "error_of.hpp"

#include <gtest/gtest.h>

#include <cmath>

using namespace digilap;

TEST(CoreHeatKernel, DefaultTimeIsCtHToTwoThirdsLToFourThirds) {
  HeatLaplacianOptions o;
  o.c_t = 0.03;
  // Given l wins over the measured one; the formula to rounding (pow is within an ulp or two).
  o.length_scale = 2.0;
  const double given = 0.03 * std::cbrt(1e-4) * std::cbrt(16.0);
  EXPECT_NEAR(heat_time(0.01, o, 5.0), given, 1e-14 * given);
  // l = 0: the measured l.
  o.length_scale = 0;
  const double measured = 0.03 * std::cbrt(1e-4) * std::cbrt(625.0);
  EXPECT_NEAR(heat_time(0.01, o, 5.0), measured, 1e-14 * measured);
  // A given t is the time, whatever h and l.
  o.t = 0.125;
  EXPECT_EQ(heat_time(0.01, o, 0.0), 0.125);
}

// t has units of length^2: scaling the shape by s (h and l together) scales t by s^2, so the
// operator of a segmentation in mm is that of the same shape in m, rescaled (issue 21).
TEST(CoreHeatKernel, TimeScalesLikeALengthSquared) {
  const HeatLaplacianOptions o;
  const double unit = heat_time(0.05, o, 1.3);
  for (double s : {1e-3, 1.0, 1e3}) EXPECT_NEAR(heat_time(0.05 * s, o, 1.3 * s) / (s * s), unit, 1e-14 * unit) << "s = " << s;
}

TEST(CoreHeatKernel, NoLengthScaleOrABadConstantIsRefused) {
  HeatLaplacianOptions o;
  EXPECT_NE(error_of([&] { heat_time(0.1, o, 0.0); }).find("give t or length_scale"), std::string::npos);
  o.c_t = -1;
  EXPECT_THROW(heat_time(0.1, o, 1.0), Error);
  o.c_t = std::nan("");
  EXPECT_THROW(heat_time(0.1, o, 1.0), Error);
  // A time so small that the kernel's prefactor 1 / (t sqrt(4 pi t)) overflows: refused, not inf.
  HeatLaplacianOptions tiny;
  tiny.t = 1e-250;
  EXPECT_NE(error_of([&] { heat_time(0.1, tiny, 1.0); }).find("too small"), std::string::npos);
  tiny.t = -1;
  EXPECT_THROW(heat_time(0.1, tiny, 1.0), Error);
}
