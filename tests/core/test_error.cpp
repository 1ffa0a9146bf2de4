// core/error.hpp: the one exception type and the two checks every step, time and grid step
// goes through; their messages say what was wrong and what would be right.
#include "digilap/core/error.hpp"
#include "error_of.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <stdexcept>

using namespace digilap;

TEST(CoreError, ErrorIsARuntimeErrorWithItsMessage) {
  try {
    throw Error("h must be > 0");
  } catch (const std::runtime_error& e) {  // callers that catch the standard type still see it
    EXPECT_STREQ(e.what(), "h must be > 0");
  }
}

TEST(CoreError, RequirePositiveRefusesZeroNegativeNanAndInf) {
  EXPECT_NO_THROW(require_positive("t", 1e-300));
  EXPECT_NO_THROW(require_positive("t", 1e300));
  EXPECT_EQ(error_of([] { require_positive("t", 0.0); }), "t must be > 0 and finite, got 0");
  EXPECT_EQ(error_of([] { require_positive("dt", -1.5); }), "dt must be > 0 and finite, got -1.5");
  EXPECT_EQ(error_of([] { require_positive("R", std::numeric_limits<double>::infinity()); }), "R must be > 0 and finite, got inf");
  EXPECT_EQ(error_of([] { require_positive("k", std::nan("")); }), "k must be > 0 and finite, got nan");
}

// The bounds are inclusive; outside them the message names the bounds and the remedy.
TEST(CoreError, GridStepsOutsideTheRepresentableRangeAreRefused) {
  EXPECT_NO_THROW(require_grid_step("h", kMinGridStep));
  EXPECT_NO_THROW(require_grid_step("h", kMaxGridStep));
  EXPECT_NO_THROW(require_grid_step("h", 0.001));
  const std::string tiny = error_of([] { require_grid_step("h", 1e-31); });
  EXPECT_NE(tiny.find("h = 1e-31 is outside [1e-30, 1e+30]"), std::string::npos) << tiny;
  EXPECT_NE(tiny.find("give the step in another unit"), std::string::npos) << tiny;
  EXPECT_NE(error_of([] { require_grid_step("h", 1e31); }).find("outside [1e-30, 1e+30]"), std::string::npos);
  EXPECT_EQ(error_of([] { require_grid_step("h", -1); }), "h must be > 0 and finite, got -1");
  // Why the range: an area h^2 N and an eigenvalue ~1 / h^2 of 10^9 cells stay normal doubles.
  EXPECT_GT(kMinGridStep * kMinGridStep, std::numeric_limits<double>::min());
  EXPECT_LT(1e9 * kMaxGridStep * kMaxGridStep, std::numeric_limits<double>::max());
}
