// The bit-pattern comparisons of quad/math/float_bits.h against the float expressions they stand for,
// on every kind of value (specials, limits and their neighbours, random patterns).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "float_cases.h"
#include "quad/math/float_bits.h"

using quad_test::bits_of;
using quad_test::interesting_floats;
using quad_test::same_float;
using namespace quad;

TEST(FloatBits, ComparisonsAgreeWithTheFloatOnesOnEveryKindOfValue) {
  const float inf = std::numeric_limits<float>::infinity();
  for (float limit : {0.0f, 0.05f, 0.17f, 0.2f, 0.3f, 1.0f, 3.0f, 11.0f, 1000.0f, inf}) {
    for (float x : interesting_floats({limit, 0.05f, 1.0f}, 20000, 7u)) {
      SCOPED_TRACE(testing::Message() << "x " << x << " limit " << limit);
      ASSERT_EQ(abs_below(x, limit), std::fabs(x) < limit);
      ASSERT_EQ(abs_at_least(x, limit), std::fabs(x) >= limit);
      ASSERT_EQ(abs_at_most(x, limit), std::fabs(x) <= limit);
      ASSERT_TRUE(clamp_abs_limit(limit));
      ASSERT_TRUE(same_float(clamp_abs(x, limit), quad::clampf(x, -limit, limit)));
      // The sign of a clamped zero too (clampf(x, -0, 0) gives -0 for x < 0).
      if (!std::isnan(x)) ASSERT_EQ(bits_of(clamp_abs(x, limit)), bits_of(quad::clampf(x, -limit, limit)));
      ASSERT_EQ(is_zero(x), x == 0.0f);
      ASSERT_EQ(is_one(x), x == 1.0f);
      ASSERT_EQ(positive(x), x > 0.0f);
      ASSERT_EQ(negative(x), x < 0.0f);
    }
  }
}

// abs_below() takes a zero limit of either sign: |x| < -0 as the float comparison decides it.
TEST(FloatBits, NegativeZeroLimitIsZero) {
  for (float x : interesting_floats({0.0f, 1e-30f}, 2000, 3u)) {
    SCOPED_TRACE(testing::Message() << "x " << x);
    ASSERT_EQ(abs_below(x, -0.0f), std::fabs(x) < -0.0f);
  }
}

// abs_at_least() takes a NaN limit of either sign: nothing is at least NaN.
TEST(FloatBits, AbsAtLeastANanLimitIsFalse) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (float limit : {nan, -nan}) {
    for (float x : interesting_floats({0.0f, 1.0f}, 2000, 5u)) ASSERT_FALSE(abs_at_least(x, limit)) << x;
  }
}

// The limits clamp_abs() takes are exactly those with the sign bit clear, up to +infinity.
TEST(FloatBits, ClampAbsLimitIsNonNegativeAndNotNan) {
  for (float limit : interesting_floats({0.0f, 1.0f}, 20000, 9u)) {
    ASSERT_EQ(clamp_abs_limit(limit), !std::isnan(limit) && !std::signbit(limit)) << limit;
  }
}
