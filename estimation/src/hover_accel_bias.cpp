#include "quad/estimation/hover_accel_bias.h"

#include "quad/math/float_bits.h"

namespace quad {
namespace est {

void HoverAccelBias::configure(float tau_s, float limit) {
  inv_tau_ = tau_s > 0.0f ? 1.0f / tau_s : 0.0f;
  limit_ = maxf(limit, 0.0f);
  if (inv_tau_ == 0.0f) reset();
  bx_ = clampf(bx_, -limit_, limit_);
  by_ = clampf(by_, -limit_, limit_);
}

// (Comparisons on the bit patterns, quad/math/float_bits.h: integer compares instead of software float
// ones on the AVR. limit_ is >= +0 and not NaN, configure() makes it so: clamp_abs() applies.)

void HoverAccelBias::update(const Vec3& accel_frd, bool hovering, float dt) {
  // inv_tau_ is +0 or positive (configure()), so == 0.0f is a zero pattern; dt > 0.0f is a pattern in
  // (0, +inf]; is_finite(accel_frd) is the scalar test on each axis (inline, no call).
  const uint32_t dt_bits = float_bits(dt);
  if (!hovering || float_bits(inv_tau_) == 0u || !is_finite(accel_frd.x) || !is_finite(accel_frd.y) ||
      !is_finite(accel_frd.z) || dt_bits == 0u || dt_bits > kFloatInfBits) {
    return;
  }
  // First-order mean, b += (a - b) dt / tau (dt << tau), of the body x and y specific force.
  // minf(dt * inv_tau_, 1.0f): the product of two positive floats is positive (or +inf).
  float k = dt * inv_tau_;
  if (float_bits(k) >= kFloatOneBits) k = 1.0f;
  bx_ = clamp_abs(bx_ + k * (accel_frd.x - bx_), limit_);
  by_ = clamp_abs(by_ + k * (accel_frd.y - by_), limit_);
}

}  // namespace est
}  // namespace quad
