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

void HoverAccelBias::update(const Vec3& accel_frd, bool hovering, float dt) {
  // (The tests on the bit patterns, float_bits.h: inv_tau_ is +0 or positive and limit_ is >= +0 and
  // not NaN, configure() makes them so.)
  if (!hovering || is_zero(inv_tau_) || !is_finite(accel_frd) || !positive(dt)) return;
  // First-order mean, b += (a - b) dt / tau (dt << tau), of the body x and y specific force; the gain
  // dt / tau is positive or +inf, so min(dt / tau, 1) is its test below one.
  float k = dt * inv_tau_;
  if (!abs_below(k, 1.0f)) k = 1.0f;
  bx_ = clamp_abs(bx_ + k * (accel_frd.x - bx_), limit_);
  by_ = clamp_abs(by_ + k * (accel_frd.y - by_), limit_);
}

}  // namespace est
}  // namespace quad
