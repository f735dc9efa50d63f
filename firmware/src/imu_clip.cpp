#include "quad/firmware/imu_clip.h"

namespace quad {
namespace fw {

namespace {

// The pattern to compare |x| against for "|x| >= limit": +0..+inf is its own pattern, a limit of -0 or
// below makes every finite reading clipped (0), a NaN limit none (no finite |x| reaches +inf's pattern).
QUAD_MATH_FN uint32_t limit_bits(float limit) {
  const uint32_t b = float_bits(limit);
  if (b <= kFloatInfBits) return b;
  if (b >= kFloatSignBit && b <= (kFloatSignBit | kFloatInfBits)) return 0u;
  return kFloatInfBits;
}

// NaN compares false and infinity is no reading at all: neither is clipping. On the bits (float_bits.h):
// is_finite(x) && absf(x) >= limit.
bool at_limit(float x, uint32_t limit) {
  const uint32_t a = abs_bits(x);
  return a < kFloatInfBits && a >= limit;
}

// One gyro axis: true when clipped; a finite reading below the limit becomes the last good value.
bool guard_axis(float x, float& last_good, uint32_t limit) {
  const uint32_t a = abs_bits(x);
  if (a >= kFloatInfBits) return false;  // non-finite: neither clipped nor good
  if (a >= limit) return true;
  last_good = x;
  return false;
}

}  // namespace

void ImuClipGuard::configure(float gyro_range, float accel_range, float hold_s) {
  gyro_limit_ = limit_bits(kClipFraction * gyro_range);
  accel_limit_ = limit_bits(kClipFraction * accel_range);
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
    if (float_bits(quiet_for_s_) < float_bits(kBurstGapS)) quiet_for_s_ += dt;
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
