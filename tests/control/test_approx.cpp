// The cheap approximations of quad/control/approx.h against the C++ library in double precision.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <vector>

#include "quad/control/approx.h"

namespace {

TEST(TanhApprox, StatedAccuracyOverTheWholeLine) {
  double worst_near = 0.0, worst_all = 0.0, worst_x = 0.0;
  for (int i = -200000; i <= 200000; ++i) {
    const float x = static_cast<float>(i) * 1e-4f;  // [-20, 20]
    const double err = std::abs(static_cast<double>(quad::ctrl::tanh_approx(x)) - std::tanh(static_cast<double>(x)));
    if (std::abs(x) <= 1.2f) worst_near = std::max(worst_near, err);
    if (err > worst_all) {
      worst_all = err;
      worst_x = x;
    }
  }
  std::printf("[figure] tanh_approx: max |error| %.2e for |x| <= 1.2, %.2e overall (at x = %.3f)\n", worst_near,
              worst_all, worst_x);
  EXPECT_LT(worst_near, 1e-6);
  EXPECT_LT(worst_all, 1.4e-3);
  EXPECT_EQ(quad::ctrl::tanh_approx(1e30f), 1.0f);
  EXPECT_EQ(quad::ctrl::tanh_approx(-1e30f), -1.0f);
  EXPECT_TRUE(std::isnan(quad::ctrl::tanh_approx(NAN)));
  EXPECT_EQ(quad::ctrl::tanh_approx(INFINITY), 1.0f);
  EXPECT_EQ(quad::ctrl::tanh_approx(-INFINITY), -1.0f);
}

TEST(TanhApprox, OddBoundedAndMonotonicUpToRounding) {
  float prev = -1.0f;
  for (int i = -100000; i <= 100000; ++i) {
    const float x = static_cast<float>(i) * 1e-4f;  // [-10, 10]
    const float y = quad::ctrl::tanh_approx(x);
    ASSERT_EQ(y, -quad::ctrl::tanh_approx(-x)) << x;
    ASSERT_LE(std::abs(y), 1.0f) << x;
    ASSERT_GE(y, prev - 4e-7f) << x;  // monotonic up to a few float rounding steps (ulp 6e-8 near 1)
    prev = y;
  }
}

// Around the switch from x^3 to x^5 (|x| = 0.06) and from x^5 to the Pade form (|x| = 0.158), every
// float in between, within the stated error. The x^3 -> x^5 switch is a step up (x - x^3/3 lies below
// tanh), so there the function is monotonic to one float rounding (ulp 7.5e-9); the x^5 -> Pade switch
// steps down by the x^5 series' truncation error, 17 x^7 / 315 = 1.3e-7.
TEST(TanhApprox, MonotonicAcrossTheBranchSwitchesFloatByFloat) {
  const struct {
    float centre, dip;
  } switches[] = {{0.06f, 1.5e-8f}, {0.158114f, 1.4e-7f}};
  for (const auto& sw : switches) {
    float x = sw.centre * 0.999f, prev = quad::ctrl::tanh_approx(x);
    double worst = 0.0;
    while (x < sw.centre * 1.001f) {
      x = std::nextafter(x, 1.0f);
      const float y = quad::ctrl::tanh_approx(x);
      ASSERT_GE(y, prev - sw.dip) << x;
      worst = std::max(worst, std::abs(double(y) - std::tanh(double(x))));
      prev = y;
    }
    EXPECT_LT(worst, 2e-7) << sw.centre;
  }
}

TEST(SincosSmall, StatedAccuracyUpToPointFourRadians) {
  double worst = 0.0;
  for (int i = -4000; i <= 4000; ++i) {
    const double a = i * 1e-4;
    const quad::ctrl::SinCos sc = quad::ctrl::sincos_small(static_cast<float>(a));
    worst = std::max({worst, std::abs(sc.s - std::sin(a)), std::abs(sc.c - std::cos(a))});
  }
  std::printf("[figure] sincos_small: max |error| %.2e on [-0.4, 0.4] rad\n", worst);
  EXPECT_LT(worst, 4e-7);
}

}  // namespace
