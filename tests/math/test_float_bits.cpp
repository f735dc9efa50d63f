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

// The comparisons with a limit on one side, each under its stated condition on the limit, against the
// float expression, on every kind of x (the ordered ones, below_positive and the like, for x not NaN).
TEST(FloatBits, OneSidedComparisonsAgreeWithTheFloatOnes) {
  const float inf = std::numeric_limits<float>::infinity();
  for (float limit : {0.0f, 1e-30f, 0.0036f, 0.5f, 1.0f, 4.9f, 13.3f, 1000.0f, inf}) {
    for (float x : interesting_floats({limit, 1.0f}, 20000, 11u)) {
      SCOPED_TRACE(testing::Message() << "x " << x << " limit " << limit);
      ASSERT_EQ(abs_above(x, limit), std::fabs(x) > limit);
      ASSERT_EQ(positive_at_most(x, limit), x > 0.0f && x <= limit);
      if (std::isnan(x)) continue;
      ASSERT_EQ(above_nonnegative(x, limit), x > limit);
      if (limit > 0.0f) {
        ASSERT_EQ(below_positive(x, limit), x < limit);
        ASSERT_EQ(at_least_positive(x, limit), x >= limit);
      }
    }
  }
}

// lo < x < hi for lo >= +0 and hi not NaN, hi below lo included (an empty band).
TEST(FloatBits, InOpenRangeAgreesWithTheFloatComparisons) {
  const float inf = std::numeric_limits<float>::infinity();
  const float bounds[] = {0.0f, 1e-30f, 0.25f, 49.0f, 144.0f, inf};
  for (float lo : bounds) {
    for (float hi : bounds) {
      for (float x : interesting_floats({lo, hi}, 5000, 13u)) {
        ASSERT_EQ(in_open_range(x, lo, hi), lo < x && x < hi) << x << " in (" << lo << ", " << hi << ")";
      }
    }
  }
}

// same_bits is equality of the patterns: equal floats of different patterns (+-0) differ, a NaN equals
// itself; whenever it holds, anything computed from a gives what it gives from b.
TEST(FloatBits, SameBitsIsEqualityOfThePatterns) {
  const std::vector<float> v = interesting_floats({0.0025f, 0.005f}, 2000, 17u);
  for (float a : v) {
    for (size_t j = 0; j < v.size(); j += 37) {
      const float b = v[j];
      ASSERT_EQ(same_bits(a, b), bits_of(a) == bits_of(b)) << a << " " << b;
    }
    ASSERT_TRUE(same_bits(a, a)) << a;
  }
  ASSERT_FALSE(same_bits(0.0f, -0.0f));
}
