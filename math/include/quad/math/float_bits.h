// Float comparisons on the bit pattern, for the hot paths on the AVR.
//
// A software float comparison costs 60-100 cycles on the ATmega2560 (a multiplication ~150, which is_one()
// can spare); these are integer operations. They rest on IEEE 754 single precision: a non-negative float
// (sign bit clear) orders like its pattern read as an unsigned integer, +infinity is 0x7F800000 and every
// NaN's pattern with the sign bit cleared is above it. Each helper returns exactly what the float
// expression in its comment returns, for every x including -0, infinities and NaN, under the stated
// condition on the limit (tests/math/test_float_bits.cpp checks them against the float expressions).
// A caller uses them only where the PIL flight on the emulated ATmega2560 (ctest pil_hover_avr_200hz)
// measured them to pay: the longest iteration at least 800 cycles (1 % of the 200 Hz period) shorter
// than with the float operations, or, for the comparisons every iteration makes, the median iteration
// shorter by the group's measured share (docs/performance.md, "Bit-pattern helpers": together they keep
// the median 200 Hz iteration below the build before the flight application was split into parts).
// Elsewhere the core writes the comparison itself.
#pragma once

#include <stdint.h>
#include <string.h>

#include "quad/math/scalar.h"  // QUAD_MATH_FN

namespace quad {

inline uint32_t float_bits(float x) {
  uint32_t b;
  memcpy(&b, &x, sizeof b);
  return b;
}

// x == 0.0f (either zero; false for NaN).
inline bool is_zero(float x) { return (float_bits(x) << 1) == 0u; }

// x == 1.0f.
inline bool is_one(float x) { return float_bits(x) == 0x3F800000u; }

// absf(x) < limit, for limit >= 0 (+0 or -0) and not NaN (false for a NaN x).
inline bool abs_below(float x, float limit) {
  return (float_bits(x) & 0x7FFFFFFFu) < (float_bits(limit) & 0x7FFFFFFFu);
}

// absf(x) <= limit, for limit >= +0 and not NaN (false for a NaN x).
inline bool abs_at_most(float x, float limit) { return (float_bits(x) & 0x7FFFFFFFu) <= float_bits(limit); }

// absf(x) >= limit, for limit >= +0 or NaN (false for a NaN x or a NaN limit).
inline bool abs_at_least(float x, float limit) {
  const uint32_t a = float_bits(x) & 0x7FFFFFFFu;
  return a >= float_bits(limit) && a <= 0x7F800000u;
}

// absf(x) > limit, for limit >= +0 and not NaN (false for a NaN x).
inline bool abs_above(float x, float limit) {
  const uint32_t a = float_bits(x) & 0x7FFFFFFFu;
  return a > float_bits(limit) && a <= 0x7F800000u;
}

// x > 0.0f (false for +-0 and NaN).
inline bool positive(float x) {
  const uint32_t b = float_bits(x);
  return b != 0u && b <= 0x7F800000u;
}

// x < 0.0f (false for -0 and NaN).
inline bool negative(float x) {
  const uint32_t b = float_bits(x);
  return b > 0x80000000u && b <= 0xFF800000u;
}

// lo < x < hi, for lo >= +0 and hi not NaN (false for a NaN x): a gate such as a squared norm's band.
inline bool in_open_range(float x, float lo, float hi) {
  const uint32_t b = float_bits(x);
  return b > float_bits(lo) && b < float_bits(hi);
}

// 0 < x <= limit, for limit >= +0 and not NaN (false for +-0 and NaN): a time step's plausibility.
inline bool positive_at_most(float x, float limit) {
  const uint32_t b = float_bits(x);
  return b != 0u && b <= float_bits(limit);
}

// a and b are the same float, bit for bit (+0 and -0 differ, a NaN equals its own pattern): the key of
// a cache of values computed from a float, which gives what recomputing gives whenever it hits.
inline bool same_bits(float a, float b) { return float_bits(a) == float_bits(b); }

// The bit pattern read as a signed integer: it orders like the float whenever one of the two compared
// is positive and neither is NaN (every negative float, -0 included, reads as a negative integer).
inline int32_t float_order(float x) {
  int32_t i;
  memcpy(&i, &x, sizeof i);
  return i;
}

// x < limit, for limit > +0 and x not NaN.
inline bool below_positive(float x, float limit) { return float_order(x) < float_order(limit); }

// x > limit, for limit >= +0 and x not NaN.
inline bool above_nonnegative(float x, float limit) { return float_order(x) > float_order(limit); }

// x >= limit, for limit > +0 and x not NaN.
inline bool at_least_positive(float x, float limit) { return float_order(x) >= float_order(limit); }

// A limit clamp_abs() takes: >= +0 and not NaN (its sign bit clear, at most +infinity).
inline bool clamp_abs_limit(float limit) { return float_bits(limit) <= 0x7F800000u; }

// clampf(x, -limit, limit) for a limit with clamp_abs_limit(limit) (a NaN x passes unchanged, as through
// clampf).
QUAD_MATH_FN float clamp_abs(float x, float limit) {
  const uint32_t b = float_bits(x);
  const uint32_t a = b & 0x7FFFFFFFu;
  const uint32_t l = float_bits(limit);
  if (a <= l || a > 0x7F800000u) return x;
  const uint32_t clamped = (b & 0x80000000u) | l;
  memcpy(&x, &clamped, sizeof x);
  return x;
}

}  // namespace quad
