#include "quad/firmware/hover_trim.h"

#include "quad/math/scalar.h"

namespace quad {
namespace fw {

void HoverTrim::configure(float ki, float limit) {
  ki_ = ki;
  limit_ = limit;
  accel_ = clampf(accel_, -limit_, limit_);
}

void HoverTrim::update(float position_error_z, float dt) {
  if (!is_finite(position_error_z) || !(dt > 0.0f)) return;
  // Integrating the acceleration itself (rather than the error, then scaling) keeps the clamp exact when
  // POS_KI_Z changes in flight.
  accel_ = clampf(accel_ - ki_ * position_error_z * dt, -limit_, limit_);
}

}  // namespace fw
}  // namespace quad
