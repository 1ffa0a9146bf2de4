// core/constants.hpp: the one pi of the library, against the C library's (correctly rounded
// acos(-1) in glibc) and against its defining property.
#include "digilap/core/constants.hpp"

#include <gtest/gtest.h>

#include <cmath>

TEST(CoreConstants, PiIsTheDoubleNearestPi) {
  EXPECT_EQ(digilap::kPi, std::acos(-1.0));
  EXPECT_EQ(digilap::kPi, 4 * std::atan(1.0));
  // sin(pi) in double is the rounding error of pi itself, ~1.2e-16: a wrong digit would be 1e-15+.
  EXPECT_LT(std::abs(std::sin(digilap::kPi)), 2e-16);
}
