#include "quad/estimation/hover_accel_bias.h"

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
  if (!hovering || inv_tau_ == 0.0f || !is_finite(accel_frd) || !(dt > 0.0f)) return;
  // First-order mean, b += (a - b) dt / tau (dt << tau), of the body x and y specific force.
  const float k = minf(dt * inv_tau_, 1.0f);
  bx_ = clampf(bx_ + k * (accel_frd.x - bx_), -limit_, limit_);
  by_ = clampf(by_ + k * (accel_frd.y - by_), -limit_, limit_);
}

}  // namespace est
}  // namespace quad
