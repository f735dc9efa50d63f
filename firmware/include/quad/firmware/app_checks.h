// The flight application's per-iteration checks, written to avoid software float work on the AVR.
//
// Each returns exactly what the float expression in its comment returns (tests/firmware/
// test_scheduler_vision.cpp, "AppChecks", compares them on boundary and random inputs): norms are
// skipped when one axis already decides the comparison, and the per-axis speed and force tests compare
// bit patterns (float_bits.h: together 1 970 cycles off the longest iteration of the 200 Hz PIL flight).
// They live here rather than in the application so that the tests can reach them.
#pragma once

#include <stdint.h>

#include "quad/firmware/params.h"
#include "quad/math/float_bits.h"
#include "quad/math/math.h"

namespace quad {
namespace fw {

constexpr float kMaxHealthySpeed = 20.0f;  // m/s: a faster estimate is a diverged filter
// m/s: the position trim does not learn along an axis the shaped setpoint moves on faster than this.
constexpr float kTrimMovingSpeed = 0.05f;
// m/s: faster than this the rotors' drag is part of the horizontal specific force: no bias learning.
constexpr float kHoverMaxSpeed = 0.3f;

// The integration step of an iteration `elapsed_us` after the last one (thesis: T of eq. 4.7 and 8.7):
//   dt = clock_started ? static_cast<float>(static_cast<int32_t>(elapsed_us)) * 1e-6f : nominal_dt, and
//   nominal_dt when that is not > 0 or above 5 nominal periods (a gap or a clock step: integrate one
//   nominal period rather than a jump); nominal_dt = static_cast<float>(period_us) * 1e-6f.
// A step exactly one period after the last (every lockstep step, most board ones) is nominal_dt without
// float work: the same conversion of the same integer, which passes both checks (or is 0 = nominal_dt).
inline float step_dt(bool clock_started, uint32_t elapsed_us, uint32_t period_us, float nominal_dt) {
  if (!clock_started || elapsed_us == period_us) return nominal_dt;
  const float dt = static_cast<float>(static_cast<int32_t>(elapsed_us)) * 1e-6f;
  return !(dt > 0.0f) || dt > 5.0f * nominal_dt ? nominal_dt : dt;
}

// Bit i set: the shaped setpoint moves along axis i (its tracking lag is not an offset to learn, nor is
// the vehicle hovering): absf(v_d[i]) >= kTrimMovingSpeed (false for NaN). One out-of-line copy for
// hovering() and the trim's learn flags.
inline __attribute__((noinline)) uint8_t moving_axes(const Vec3& v_d) {
  return static_cast<uint8_t>((abs_at_least(v_d.x, kTrimMovingSpeed) ? 1u : 0u) |
                              (abs_at_least(v_d.y, kTrimMovingSpeed) ? 2u : 0u) |
                              (abs_at_least(v_d.z, kTrimMovingSpeed) ? 4u : 0u));
}

// Hovering's speed test norm_sq(v) < sqf(kHoverMaxSpeed), without the norm when each |v_i| <= 0.17 m/s
// (exactly: rounding is monotonic, so the sum of squares is then at most 0.0867 < 0.09).
constexpr float kHoverSureSpeed = 0.17f;
inline bool slow_for_hover(const Vec3& v) {
  if (abs_at_most(v.x, kHoverSureSpeed) && abs_at_most(v.y, kHoverSureSpeed) && abs_at_most(v.z, kHoverSureSpeed)) {
    return true;
  }
  return norm_sq(v) < sqf(kHoverMaxSpeed);
}

// The estimator's speed test is_finite(v) && norm_sq(v) < sqf(kMaxHealthySpeed), without the norm when
// each |v_i| <= 11 m/s (then the sum of squares is at most 363, exact in float, below 400).
constexpr float kHealthySureSpeed = 11.0f;
inline bool healthy_speed(const Vec3& v) {
  if (abs_at_most(v.x, kHealthySureSpeed) && abs_at_most(v.y, kHealthySureSpeed) && abs_at_most(v.z, kHealthySureSpeed)) {
    return true;
  }
  return is_finite(v) && norm_sq(v) < sqf(kMaxHealthySpeed);
}

// The specific-force plausibility test norm_sq(a) > sqf(0.3f * kGravity) (8.66), without the norm when
// |a_z| >= 3 (gravity is mostly along body z: its square alone is >= 9, and a sum of non-negative floats
// is at least each term). The caller has checked that a is finite.
constexpr float kSureForce = 3.0f;
inline bool plausible_force(const Vec3& a) {
  if (abs_at_least(a.z, kSureForce)) return true;
  return norm_sq(a) > sqf(0.3f * kGravity);
}

// MAG_OFS zero and MAG_SI the identity (the parameters' defaults): thesis eq. 7.5 returns the field
// itself (W (m - b) = m for every finite field, but for the sign of an exact zero component; a
// non-finite field stays non-finite; a -0 parameter counts as zero, which changes only the sign of an
// exact zero component). The twelve parameters are consecutive: offsets, then W by rows.
static_assert(kMagSiXX == kMagOfsX + 3 && kMagSiZZ == kMagOfsX + 11, "MAG_OFS_*, MAG_SI_* order");
inline bool identity_calibration(const Params& p) {
  for (uint8_t i = 0; i < 12; ++i) {
    const float expected = i == 3 || i == 7 || i == 11 ? 1.0f : 0.0f;  // 1 on W's diagonal
    if (p.get(static_cast<uint8_t>(kMagOfsX + i)) != expected) return false;
  }
  return true;
}

}  // namespace fw
}  // namespace quad
