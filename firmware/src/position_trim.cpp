#include "quad/firmware/position_trim.h"

#include "quad/math/scalar.h"

namespace quad {
namespace fw {

void AxisTrim::configure(float ki, float limit) {
  ki_ = ki;
  limit_ = limit;
  accel_ = clampf(accel_, -limit_, limit_);
}

void AxisTrim::update(float position_error, float dt) {
  if (!is_finite(position_error) || !(dt > 0.0f)) return;
  // An offset is small; a large error is a transient (a jump of the fix, a gust, the first seconds of a
  // fault) that the PD law handles and that would wind the integral up: learn at most at the rate of
  // kMaxLearnedError. Integrating the acceleration itself (rather than the error, then scaling) keeps
  // the clamp exact when the gain changes in flight.
  const float e = clampf(position_error, -kMaxLearnedError, kMaxLearnedError);
  accel_ = clampf(accel_ - ki_ * e * dt, -limit_, limit_);
}

void PositionTrim::configure(float ki_xy, float limit_xy, float ki_z, float limit_z) {
  axis_[0].configure(ki_xy, limit_xy);
  axis_[1].configure(ki_xy, limit_xy);
  axis_[2].configure(ki_z, limit_z);
}

void PositionTrim::reset() {
  for (AxisTrim& a : axis_) a.reset();
}

void PositionTrim::update(const Vec3& position_error, const bool learn[3], float dt) {
  for (int i = 0; i < 3; ++i) {
    if (learn[i]) axis_[i].update(position_error[i], dt);
  }
}

}  // namespace fw
}  // namespace quad
