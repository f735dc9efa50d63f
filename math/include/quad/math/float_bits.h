// Float comparisons and halving on the bit pattern, for the hot paths on the AVR.
//
// A software float compare costs 60-100 cycles on the ATmega2560 and a multiplication ~150; these are
// integer operations. They rest on IEEE 754 single precision: a non-negative float (sign bit clear)
// orders like its pattern read as an unsigned integer, +infinity is 0x7F800000 and every NaN's pattern
// with the sign bit cleared is above it. Each helper returns exactly what the float expression in its
// comment returns, for every x including -0, infinities and NaN, under the stated condition on the limit
// (tests/math/test_float_bits.cpp checks them against the float expressions).
#pragma once

#include <stdint.h>
#include <string.h>

#include "quad/math/scalar.h"  // QUAD_MATH_FN

namespace quad {

constexpr uint32_t kFloatSignBit = 0x80000000u;
constexpr uint32_t kFloatInfBits = 0x7F800000u;
constexpr uint32_t kFloatOneBits = 0x3F800000u;  // 1.0f

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

// The pattern of absf(x) (NaN patterns stay above every number's).
inline uint32_t abs_bits(float x) { return float_bits(x) & ~kFloatSignBit; }

// absf(x) < limit, limit >= 0 (+0 or -0) and not NaN (false for a NaN x: its pattern is above every limit).
inline bool abs_below(float x, float limit) { return abs_bits(x) < abs_bits(limit); }

// absf(x) >= limit, limit >= 0 and not NaN (false for a NaN x).
inline bool abs_at_least(float x, float limit) {
  const uint32_t a = abs_bits(x);
  return a >= abs_bits(limit) && a <= kFloatInfBits;
}

// absf(x) <= limit, limit >= 0 and not NaN (false for a NaN x).
inline bool abs_at_most(float x, float limit) { return abs_bits(x) <= abs_bits(limit); }

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

// 0.5f * x computed on the bits: for a normal x whose half is normal, one less in the exponent field;
// zero, subnormal, infinite and NaN operands go through the multiplication. Bit-identical to 0.5f * x.
float exact_half(float x);

// x / 2 in the hot paths: exact_half() on the AVR (an integer subtraction against a ~150-cycle software
// multiplication), the multiplication on targets with an FPU. Bit-identical either way.
inline float half(float x) {
#if defined(QUAD_TARGET_AVR)
  return exact_half(x);
#else
  return 0.5f * x;
#endif
}

}  // namespace quad
