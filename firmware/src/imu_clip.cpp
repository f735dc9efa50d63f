#include "quad/firmware/imu_clip.h"

#include "quad/math/float_bits.h"

namespace quad {
namespace fw {

namespace {

// The limit |x| is compared with (abs_at_least() needs one without the sign bit): a limit of zero or below
// becomes +0 and makes every finite reading clipped; a NaN limit stays and clips none, as the float
// comparison absf(x) >= limit would decide.
float clip_limit(float limit) { return limit <= 0.0f ? 0.0f : limit; }

// NaN compares false and infinity is no reading at all: neither is clipping. The comparisons are on
// the bit patterns (float_bits.h: 1 420 cycles off the longest iteration of the 200 Hz PIL flight).
bool at_limit(float x, float limit) { return is_finite(x) && abs_at_least(x, limit); }

// One gyro axis: true when clipped; a finite reading below the limit becomes the last good value.
bool guard_axis(float x, float& last_good, float limit) {
  if (!is_finite(x)) return false;  // neither clipped nor good
  if (abs_at_least(x, limit)) return true;
  last_good = x;
  return false;
}

}  // namespace

void ImuClipGuard::configure(float gyro_range, float accel_range, float hold_s) {
  gyro_limit_ = clip_limit(kClipFraction * gyro_range);
  accel_limit_ = clip_limit(kClipFraction * accel_range);
  hold_s_ = hold_s;
}

Vec3 ImuClipGuard::update(const hal::ImuSample& raw, float dt) {
  Vec3 gyro = raw.gyro;
  // Each axis is looked at (no short circuit: every finite unclipped axis updates its last good value).
  const bool gx = guard_axis(raw.gyro.x, last_good_gyro_.x, gyro_limit_);
  const bool gy = guard_axis(raw.gyro.y, last_good_gyro_.y, gyro_limit_);
  const bool gz = guard_axis(raw.gyro.z, last_good_gyro_.z, gyro_limit_);
  const bool gyro_clipped = gx || gy || gz;
  const bool accel_clipped =
      at_limit(raw.accel.x, accel_limit_) || at_limit(raw.accel.y, accel_limit_) || at_limit(raw.accel.z, accel_limit_);

  gyro_clipped_ = gyro_clipped;
  accel_clipped_ = accel_clipped;
  burst_started_ = false;
  if (!gyro_clipped && !accel_clipped) {
    clipping_for_s_ = 0.0f;
    // Only quiet_for_s_ >= kBurstGapS is ever read: once there (dt > 0 adds to it) it stays, so the sum
    // stops growing (one float addition saved per sample in the common, quiet case).
    if (below_positive(quiet_for_s_, kBurstGapS)) quiet_for_s_ += dt;  // (a sum of periods: not NaN)
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
  if (gx) gyro.x = last_good_gyro_.x;
  if (gy) gyro.y = last_good_gyro_.y;
  if (gz) gyro.z = last_good_gyro_.z;
  return gyro;
}

}  // namespace fw
}  // namespace quad
