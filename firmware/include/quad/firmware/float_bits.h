// Float comparisons on the bit pattern, for the application's hot path on the AVR.
//
// A software float compare costs 60-100 cycles on the ATmega2560; these are integer compares. They rest
// on IEEE 754 single precision: a non-negative float (sign bit clear) orders like its pattern read as an
// unsigned integer, +infinity is 0x7F800000 and every NaN's pattern with the sign bit cleared is above
// it. Each helper returns exactly what the float expression in its comment returns, for every x
// including -0, infinities and NaN (tests/firmware/test_float_bits.cpp checks them against the float
// expressions), under the stated condition on the limit.
#pragma once

#include <stdint.h>
#include <string.h>

#include "quad/math/scalar.h"  // QUAD_MATH_FN

namespace quad {
namespace fw {

constexpr uint32_t kFloatSignBit = 0x80000000u;
constexpr uint32_t kFloatInfBits = 0x7F800000u;

inline uint32_t float_bits(float x) {
  uint32_t b;
  memcpy(&b, &x, sizeof b);
  return b;
}

inline float float_of_bits(uint32_t b) {
  float x;
  memcpy(&x, &b, sizeof x);
  return x;
}

inline uint32_t abs_bits(float x) { return float_bits(x) & ~kFloatSignBit; }

// absf(x) < limit, limit >= +0 and not NaN (false for a NaN x: its pattern is above every limit).
inline bool abs_below(float x, float limit) { return abs_bits(x) < float_bits(limit); }

// absf(x) >= limit, limit >= +0 and not NaN (false for a NaN x).
inline bool abs_at_least(float x, float limit) {
  const uint32_t a = abs_bits(x);
  return a >= float_bits(limit) && a <= kFloatInfBits;
}

// absf(x) <= limit, limit >= +0 and not NaN (false for a NaN x).
inline bool abs_at_most(float x, float limit) { return abs_bits(x) <= float_bits(limit); }

// clampf(x, -limit, limit), limit >= +0 and not NaN (a NaN x passes unchanged, as through clampf).
QUAD_MATH_FN float clamp_abs(float x, float limit) {
  const uint32_t b = float_bits(x);
  const uint32_t a = b & ~kFloatSignBit;
  const uint32_t l = float_bits(limit);
  if (a <= l || a > kFloatInfBits) return x;
  return float_of_bits((b & kFloatSignBit) | l);
}

// x > 0.0f (false for +-0 and NaN).
inline bool positive(float x) {
  const uint32_t b = float_bits(x);
  return b != 0u && b <= kFloatInfBits;
}

// x < 0.0f (the sign bit set, not -0 and not a NaN).
inline bool negative(float x) {
  const uint32_t b = float_bits(x);
  return b > kFloatSignBit && b <= (kFloatSignBit | kFloatInfBits);
}

// x + 0.0f: x itself, except -0 becomes +0 (as in IEEE round-to-nearest; a NaN stays a NaN).
inline float plus_zero(float x) { return float_bits(x) == kFloatSignBit ? 0.0f : x; }

}  // namespace fw
}  // namespace quad
