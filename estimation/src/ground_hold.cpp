#include "quad/estimation/ground_hold.h"

namespace quad {
namespace est {

void GroundHold::configure(const GroundHoldParams& p) {
  gyro_max2_ = sqf(p.gyro_max);
  const float lo = maxf(kGravity - p.accel_max, 0.0f);
  accel_lo2_ = sqf(lo);
  accel_hi2_ = sqf(kGravity + p.accel_max);
  still_time_s_ = p.still_time_s;
}

bool GroundHold::update(bool on_ground, const Vec3& gyro, const Vec3& accel, float dt) {
  // Off the ground nothing is held: the still time counts from the ground on (and the flying
  // iterations skip the norms: AVR cycles). (Non-finite samples compare false: not still.)
  bool still_now = on_ground;
  if (still_now) {
    const float a2 = dot(accel, accel);
    still_now = dot(gyro, gyro) < gyro_max2_ && a2 > accel_lo2_ && a2 < accel_hi2_;
  }
  if (!still_now) {
    still_for_s_ = 0.0f;
  } else if (still_for_s_ < still_time_s_) {
    still_for_s_ += dt;  // (stops counting once still: no growth without bound)
  }
  const bool was_holding = holding_;
  holding_ = on_ground && still();
  started_ = holding_ && !was_holding;
  return holding_;
}

}  // namespace est
}  // namespace quad
