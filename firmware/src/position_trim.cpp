#include "quad/firmware/position_trim.h"

#include "quad/math/scalar.h"

namespace quad {
namespace fw {

void AxisTrim::clamp(float limit) { accel_ = clampf(accel_, -limit, limit); }

void AxisTrim::update(float position_error, float dt, float ki, float limit) {
  if (!is_finite(position_error) || !(dt > 0.0f)) return;
  // An offset is small; a large error is a transient (a jump of the fix, a gust, the first seconds of a
  // fault) that the PD law handles and that would wind the integral up: learn at most at the rate of
  // kMaxLearnedError. Integrating the acceleration itself (rather than the error, then scaling) keeps
  // the clamp exact when the gain changes in flight.
  const float e = clampf(position_error, -kMaxLearnedError, kMaxLearnedError);
  accel_ = clampf(accel_ - ki * e * dt, -limit, limit);
}

void PositionTrim::configure(float ki_xy, float limit_xy, float ki_z, float limit_z) {
  ki_[0] = ki_xy;
  ki_[1] = ki_z;
  limit_[0] = limit_xy;
  limit_[1] = limit_z;
  for (int i = 0; i < 3; ++i) axis_[i].clamp(limit_[i == 2 ? 1 : 0]);
}

void PositionTrim::reset() {
  for (AxisTrim& a : axis_) a.reset();
}

void PositionTrim::update(const Vec3& position_error, const bool learn[3], float dt) {
  for (int i = 0; i < 3; ++i) {
    const int c = i == 2 ? 1 : 0;
    if (learn[i]) axis_[i].update(position_error[i], dt, ki_[c], limit_[c]);
  }
}

}  // namespace fw
}  // namespace quad
