#include "quad/estimation/hover_accel_bias.h"

#include <string.h>

namespace quad {
namespace est {

void HoverAccelBias::configure(float tau_s, float limit) {
  inv_tau_ = tau_s > 0.0f ? 1.0f / tau_s : 0.0f;
  limit_ = maxf(limit, 0.0f);
  if (inv_tau_ == 0.0f) reset();
  bx_ = clampf(bx_, -limit_, limit_);
  by_ = clampf(by_, -limit_, limit_);
}

namespace {

// Comparisons on the bit patterns (a non-negative float orders like its pattern as an unsigned integer;
// +inf is 0x7F800000, a NaN is above it): integer compares instead of software float ones on the AVR.
uint32_t bits_of(float x) {
  uint32_t b;
  memcpy(&b, &x, sizeof b);
  return b;
}
constexpr uint32_t kSign = 0x80000000u;
constexpr uint32_t kInf = 0x7F800000u;
constexpr uint32_t kOne = 0x3F800000u;  // 1.0f

// clampf(x, -limit, limit) for limit >= +0, not NaN (limit_ always is: configure()); NaN x passes.
QUAD_MATH_FN float clamp_sym(float x, float limit) {
  const uint32_t b = bits_of(x);
  const uint32_t a = b & ~kSign;
  const uint32_t l = bits_of(limit);
  if (a <= l || a > kInf) return x;
  const uint32_t r = (b & kSign) | l;
  memcpy(&x, &r, sizeof x);
  return x;
}

}  // namespace

void HoverAccelBias::update(const Vec3& accel_frd, bool hovering, float dt) {
  // inv_tau_ is +0 or positive (configure()), so == 0.0f is a zero pattern; dt > 0.0f is a pattern in
  // (0, +inf]; is_finite(accel_frd) is the scalar test on each axis (inline, no call).
  const uint32_t dt_bits = bits_of(dt);
  if (!hovering || bits_of(inv_tau_) == 0u || !is_finite(accel_frd.x) || !is_finite(accel_frd.y) ||
      !is_finite(accel_frd.z) || dt_bits == 0u || dt_bits > kInf) {
    return;
  }
  // First-order mean, b += (a - b) dt / tau (dt << tau), of the body x and y specific force.
  // minf(dt * inv_tau_, 1.0f): the product of two positive floats is positive (or +inf).
  float k = dt * inv_tau_;
  if (bits_of(k) >= kOne) k = 1.0f;
  bx_ = clamp_sym(bx_ + k * (accel_frd.x - bx_), limit_);
  by_ = clamp_sym(by_ + k * (accel_frd.y - by_), limit_);
}

}  // namespace est
}  // namespace quad
