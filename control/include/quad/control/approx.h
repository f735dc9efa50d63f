// Cheap approximations for the control loop on the 16 MHz ATmega2560, where one tanhf() or sinf() costs
// thousands of cycles. Each states its accuracy; tests/control/test_approx.cpp checks it against the
// C++ library in double precision.
//
// Usage:
//   float t = quad::ctrl::tanh_approx(x);              // |error| < 1e-4 everywhere, < 2e-6 for |x| <= 3
//   quad::ctrl::SinCos h = quad::ctrl::sincos_small(a); // |a| <= 0.8 rad
#pragma once

#include "quad/math/scalar.h"

namespace quad {
namespace ctrl {

// tanh by the [7/6] Pade approximant from Lambert's continued fraction,
//   tanh x ~ x (135135 + 17325 x^2 + 378 x^4 + x^6) / (135135 + 62370 x^2 + 3150 x^4 + 28 x^6),
// which is odd and monotonic on |x| < 4.97 (in float, to within 4e-7 of round-off), where it reaches
// 0.9999994; beyond, the result is +-1. Absolute error including float round-off (tested against
// std::tanh): below 2e-6 for |x| <= 3 (the approximant itself: 1e-12 at 1, 9.4e-7 at 3), below 1e-4 everywhere (the largest
// is at the clamp, 1 - tanh(4.97) = 9.6e-5). One division and seven multiplications; in the position
// controller an error of 1e-4 is 4e-4 m/s^2 of commanded acceleration at the thesis gains.
inline float tanh_approx(float x) {
  constexpr float kClamp = 4.97f;
  if (x >= kClamp) return 1.0f;
  if (x <= -kClamp) return -1.0f;
  const float x2 = x * x;
  const float num = x * (135135.0f + x2 * (17325.0f + x2 * (378.0f + x2)));
  const float den = 135135.0f + x2 * (62370.0f + x2 * (3150.0f + x2 * 28.0f));
  return clampf(num / den, -1.0f, 1.0f);
}

struct SinCos {
  float s = 0.0f;
  float c = 1.0f;
};

// sin and cos by their Taylor series to x^7 / x^8: absolute error below 1e-6 for |a| <= 0.8 rad (tested),
// no division. Meant for half angles of tilt commands (|a| <= 0.8 covers tilts up to 90 deg).
inline SinCos sincos_small(float a) {
  const float a2 = a * a;
  SinCos r;
  r.s = a * (1.0f - a2 * (1.0f / 6.0f) * (1.0f - a2 * (1.0f / 20.0f) * (1.0f - a2 * (1.0f / 42.0f))));
  r.c = 1.0f - a2 * 0.5f * (1.0f - a2 * (1.0f / 12.0f) * (1.0f - a2 * (1.0f / 30.0f) * (1.0f - a2 * (1.0f / 56.0f))));
  return r;
}

}  // namespace ctrl
}  // namespace quad
