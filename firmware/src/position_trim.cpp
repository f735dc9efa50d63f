#include "quad/firmware/position_trim.h"

#include "quad/math/float_bits.h"

#include "quad/math/scalar.h"

namespace quad {
namespace fw {

void AxisTrim::clamp(float limit) { accel_ = clampf(accel_, -limit, limit); }

void AxisTrim::update(float position_error, float dt, float ki, float limit) {
  if (!positive(dt)) return;
  learn(position_error, dt, ki, limit);
}

void AxisTrim::learn(float position_error, float dt, float ki, float limit) {
  if (!is_finite(position_error)) return;
  // An offset is small; a large error is a transient (a jump of the fix, a gust, the first seconds of a
  // fault) that the PD law handles and that would wind the integral up: learn at most at the rate of
  // kMaxLearnedError. Integrating the acceleration itself (rather than the error, then scaling) keeps
  // the clamp exact when the gain changes in flight. The clamps compare bit patterns (float_bits.h:
  // 1 370 cycles off the longest iteration of the 200 Hz PIL flight).
  const float e = clamp_abs(position_error, kMaxLearnedError);
  const float a = accel_ - ki * e * dt;
  accel_ = clamp_abs_limit(limit) ? clamp_abs(a, limit) : clampf(a, -limit, limit);
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
  if (!positive(dt)) return;  // each axis would refuse it (AxisTrim::update): tested once
  if (learn[0]) axis_[0].learn(position_error.x, dt, ki_[0], limit_[0]);
  if (learn[1]) axis_[1].learn(position_error.y, dt, ki_[0], limit_[0]);
  if (learn[2]) axis_[2].learn(position_error.z, dt, ki_[1], limit_[1]);
}

}  // namespace fw
}  // namespace quad
