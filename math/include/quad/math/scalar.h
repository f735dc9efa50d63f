// Scalar helpers for the freestanding flight core.
//
// Only <math.h> and <stdint.h> from the C library are used: avr-libc, newlib and glibc all provide
// them, and none of them needs a heap. Every function here takes and returns float; the `f` suffixes
// keep the host build from silently promoting to double (the AVR has no double anyway).
#pragma once

#include <math.h>
#include <stdint.h>
#include <string.h>

// Vector, quaternion and matrix operations are inline on the 32-bit targets (the FPU does them in a few
// cycles each, so inlining wins) and out of line on the AVR: there every float operation is a call into
// the software float library with its operands moved into registers, about 40 bytes of code each, so an
// inlined three-component expression costs more flash than a call does; the call itself costs under 20
// cycles against 140-500 for each float operation inside (docs/targets.md, "Memory").
#if defined(QUAD_TARGET_AVR)
#define QUAD_MATH_FN inline __attribute__((noinline))
#else
#define QUAD_MATH_FN inline
#endif

// A named step of a longer function, split out for the reader: inlined into its one caller, so that the
// split costs no call, no copies of its operands and no stack frame on the AVR.
#define QUAD_STEP inline __attribute__((always_inline))

namespace quad {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kTwoPi = 6.28318530717958647692f;
constexpr float kHalfPi = 1.57079632679489661923f;
constexpr float kGravity = 9.80665f;  // standard gravity, m/s^2
constexpr float kDegToRad = kPi / 180.0f;
constexpr float kRadToDeg = 180.0f / kPi;

// isfinite() is a macro on some C libraries and a function taking double on others (avr-libc);
// inspecting the exponent bits behaves the same on every target and never touches the FPU flags.
inline bool is_finite(float x) {
  uint32_t bits;
  memcpy(&bits, &x, sizeof bits);
  return (bits & 0x7F800000u) != 0x7F800000u;
}

inline float clampf(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }
inline float minf(float a, float b) { return a < b ? a : b; }
inline float maxf(float a, float b) { return a > b ? a : b; }
inline float absf(float x) { return x < 0.0f ? -x : x; }
inline float signf(float x) { return x < 0.0f ? -1.0f : 1.0f; }  // sign(0) = +1, as the controllers want
inline float sqf(float x) { return x * x; }

// Square root that is 0 for negative round-off instead of NaN.
inline float safe_sqrtf(float x) { return x > 0.0f ? sqrtf(x) : 0.0f; }

// asin with its argument clamped to [-1, 1], so round-off near +-90 deg never yields NaN.
inline float safe_asinf(float x) { return asinf(clampf(x, -1.0f, 1.0f)); }

// Wrap an angle to (-pi, pi]. Angles a few turns away (the common case) take the loop; larger ones go
// through fmodf so the result is bounded for every finite input (subtracting 2 pi from 1e10 rad would
// never change it).
inline float wrap_pi(float a) {
  if (!is_finite(a)) return a;
  if (a > 4.0f * kTwoPi || a < -4.0f * kTwoPi) a = fmodf(a, kTwoPi);
  while (a > kPi) a -= kTwoPi;
  while (a <= -kPi) a += kTwoPi;
  return a;
}

// sin(x)/x, exact away from 0 and a Taylor series near it (thesis eq. 4.14 needs sinc(0) = 1).
inline float sincf(float x) {
  const float x2 = x * x;
  if (x2 < 1e-4f) return 1.0f - x2 * (1.0f / 6.0f) + x2 * x2 * (1.0f / 120.0f);
  return sinf(x) / x;
}

}  // namespace quad
