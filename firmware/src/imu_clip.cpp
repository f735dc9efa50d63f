#include "quad/firmware/imu_clip.h"

namespace quad {
namespace fw {

namespace {

// NaN compares false and infinity is no reading at all: neither is clipping.
bool at_limit(float x, float limit) { return is_finite(x) && absf(x) >= limit; }

}  // namespace

void ImuClipGuard::configure(float gyro_range, float accel_range, float hold_s) {
  gyro_limit_ = kClipFraction * gyro_range;
  accel_limit_ = kClipFraction * accel_range;
  hold_s_ = hold_s;
}

Vec3 ImuClipGuard::update(const hal::ImuSample& raw, float dt) {
  Vec3 gyro = raw.gyro;
  bool gyro_clipped = false;
  for (int i = 0; i < 3; ++i) {
    if (at_limit(raw.gyro[i], gyro_limit_)) {
      gyro_clipped = true;
    } else if (is_finite(raw.gyro[i])) {
      last_good_gyro_[i] = raw.gyro[i];
    }
  }
  const bool accel_clipped =
      at_limit(raw.accel.x, accel_limit_) || at_limit(raw.accel.y, accel_limit_) || at_limit(raw.accel.z, accel_limit_);

  gyro_clipped_ = gyro_clipped;
  accel_clipped_ = accel_clipped;
  burst_started_ = false;
  if (!gyro_clipped && !accel_clipped) {
    clipping_for_s_ = 0.0f;
    quiet_for_s_ += dt;
    return gyro;
  }
  ++clipped_samples_;
  if (quiet_for_s_ >= kBurstGapS) {
    burst_started_ = true;
    ++bursts_;
  }
  quiet_for_s_ = 0.0f;
  clipping_for_s_ += dt;
  if (!healthy()) return gyro;
  for (int i = 0; i < 3; ++i) {
    if (at_limit(raw.gyro[i], gyro_limit_)) gyro[i] = last_good_gyro_[i];
  }
  return gyro;
}

}  // namespace fw
}  // namespace quad
