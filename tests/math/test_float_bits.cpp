// The bit-pattern helpers of quad/math/float_bits.h against the float expressions they replace, on
// every kind of value (specials, limits and their neighbours, random patterns).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
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
      ASSERT_TRUE(same_float(clamp_abs(x, limit), quad::clampf(x, -limit, limit)));
      // The sign of a clamped zero too (clampf(x, -0, 0) gives -0 for x < 0).
      if (!std::isnan(x)) ASSERT_EQ(bits_of(clamp_abs(x, limit)), bits_of(quad::clampf(x, -limit, limit)));
      ASSERT_EQ(positive(x), x > 0.0f);
      ASSERT_EQ(negative(x), x < 0.0f);
      ASSERT_TRUE(same_float(plus_zero(x), x + 0.0f));
      if (!std::isnan(x)) ASSERT_EQ(bits_of(plus_zero(x)), bits_of(x + 0.0f));
    }
  }
}

// A zero limit of either sign: |x| < -0, |x| >= -0 and |x| <= -0 as the float comparisons decide them.
TEST(FloatBits, NegativeZeroLimitIsZero) {
  for (float x : interesting_floats({0.0f, 1e-30f}, 2000, 3u)) {
    SCOPED_TRACE(testing::Message() << "x " << x);
    ASSERT_EQ(abs_below(x, -0.0f), std::fabs(x) < -0.0f);
    ASSERT_EQ(abs_at_least(x, -0.0f), std::fabs(x) >= -0.0f);
    ASSERT_EQ(abs_at_most(x, -0.0f), std::fabs(x) <= -0.0f);
  }
}

TEST(ExactHalf, IsBitIdenticalToMultiplyingByOneHalf) {
  // Every exponent and both signs, mantissas on a stride (zero, subnormals, the smallest normal exponent,
  // infinity and NaN take the multiplication; the rest the exponent field).
  uint64_t checked = 0;
  for (uint32_t sign = 0; sign < 2; ++sign) {
    for (uint32_t e = 0; e < 256; ++e) {
      // every mantissa at exponent field 2 (the smallest the bit path takes), 1 in 61 next to it and at
      // the fallback's exponents (0, 1, 254, 255), 1 in 4093 elsewhere
      const uint32_t stride = e == 2 ? 1u : (e <= 3 || e >= 254 ? 61u : 4093u);
      for (uint32_t m = 0; m < (1u << 23); m += stride) {
        const uint32_t b = (sign << 31) | (e << 23) | m;
        float x;
        std::memcpy(&x, &b, sizeof x);
        const float want = 0.5f * x;
        const float got = quad::exact_half(x);
        if (std::isnan(want)) {
          ASSERT_TRUE(std::isnan(got)) << std::hex << b;
        } else {
          ASSERT_EQ(bits_of(got), bits_of(want)) << std::hex << b;
        }
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 17000000u);
}
