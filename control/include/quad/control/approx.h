// Cheap approximations for the control loop on the 16 MHz ATmega2560, where one tanhf() or sinf() costs
// thousands of cycles. Each states its accuracy; tests/control/test_approx.cpp checks it against the
// C++ library in double precision.
//
// Usage:
//   float t = quad::ctrl::tanh_approx(x);              // |error| < 1.4e-3, < 1e-6 for |x| <= 1.2
//   quad::ctrl::SinCos h = quad::ctrl::sincos_small(a); // |a| <= 0.4 rad
#pragma once

#include "quad/math/float_bits.h"
#include "quad/math/scalar.h"
#include "quad/math/vec3.h"

namespace quad {
namespace ctrl {

// x > 0 and finite, for the parameter checks (validate()). Out of line on the AVR (one call instead of a
// finiteness test and a soft-float comparison at each of the ~30 checks).
QUAD_MATH_FN bool positive_finite(float x) { return is_finite(x) && x > 0.0f; }
QUAD_MATH_FN bool positive_finite(const Vec3& v) {
  return positive_finite(v.x) && positive_finite(v.y) && positive_finite(v.z);
}

// tanh by the [5/4] Pade approximant from Lambert's continued fraction,
//   tanh x ~ x (945 + 105 x^2 + x^4) / (945 + 420 x^2 + 15 x^4),
// which is odd and increasing and reaches 1 at |x| = 3.647; from there on the result is +-1, so the
// function is continuous, bounded by 1 and has slope 1 at 0 (the linear gains of eq. 8.20 are exact).
// Below |x| = 0.158 (x^2 < 0.025), where a hovering vehicle's errors usually are, the Taylor series to
// x^5 replaces it and saves the division; its truncation error 17 x^7 / 315 stays below 1.3e-7 there,
// small enough that the switch to the Pade form keeps the function monotonic up to float rounding.
// Below |x| = 0.06 (x^2 < 0.0036), the centimetre-level errors of a steady hover, the series stops at
// x^3 (two multiplications, one addition): its truncation error 2 |x|^5 / 15 stays below 1.1e-7, and
// since x - x^3/3 lies below tanh and the x^5 series above it, the switch between them is a step up, so
// the function stays monotonic.
// Absolute error (tested against std::tanh, float round-off included): below 1e-6 for |x| <= 1.2,
// below 1.4e-3 everywhere (largest near the clamp). AVR (cycle bench): 920 cycles in the x^5 branch
// (the x^3 one saves two multiplications and an addition of it, about 440), 1 860 in the Pade branch,
// against 3 400 for avr-libc's tanh (docs/performance.md).
// In the position controller the error is at most 1.4e-3 (k_p + k_v) of commanded acceleration,
// 0.02 m/s^2 (0.1 deg of tilt) at the thesis gains.
inline float tanh_approx(float x) {
  constexpr float kClamp = 3.647f;
  const float x2 = x * x;  // the common small cases first: no clamp comparisons (software on the AVR)
  // x2 is >= +0 or NaN: |x2| < c is x2 < c, on the bit pattern (float_bits.h: 210 cycles off the median
  // 200 Hz PIL iteration; a NaN goes on to the rational form and comes back as NaN).
  if (abs_below(x2, 0.0036f)) return x - x * x2 * (1.0f / 3.0f);
  if (abs_below(x2, 0.025f)) return x + x * x2 * (-1.0f / 3.0f + x2 * (2.0f / 15.0f));
  if (abs_at_least(x2, kClamp * kClamp)) return negative(x) ? -1.0f : 1.0f;  // |x| >= 3.647, both signs
  const float num = x * (945.0f + x2 * (105.0f + x2));
  const float den = 945.0f + x2 * (420.0f + x2 * 15.0f);
  const float r = num / den;
  // |r| <= 1 (round-off near the clamp could exceed it by an ulp), sign kept.
  if (abs_above(r, 1.0f)) return negative(r) ? -1.0f : 1.0f;
  return r;
}

struct SinCos {
  float s = 0.0f;
  float c = 1.0f;
};

// sin and cos by their Taylor series to a^5 / a^6: absolute error below 4e-7 for |a| <= 0.4 rad
// (tested), no division, seven multiplications. Meant for half angles of tilt commands (|a| <= 0.4
// covers tilts up to 45 deg) and for small per-step rotations.
inline SinCos sincos_small(float a) {
  const float a2 = a * a;
  SinCos r;
  r.s = a * (1.0f + a2 * (-1.0f / 6.0f + a2 * (1.0f / 120.0f)));
  r.c = 1.0f + a2 * (-0.5f + a2 * (1.0f / 24.0f + a2 * (-1.0f / 720.0f)));
  return r;
}

}  // namespace ctrl
}  // namespace quad
