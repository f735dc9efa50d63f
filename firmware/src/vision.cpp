#include "quad/firmware/vision.h"

#include "quad/math/float_bits.h"

namespace quad {
namespace fw {
namespace {

// Rounded to the nearest of 32767 steps per unit: clampf(x, -1, 1) * 32767, then +-0.5 and truncation.
// The clamp and the sign test compare bit patterns (float_bits.h: 1 720 cycles off the longest iteration
// of the 200 Hz PIL flight, with the hemisphere test below).
int16_t quantise(float x) {
  const float s = clamp_abs(x, 1.0f) * 32767.0f;
  return static_cast<int16_t>(negative(s) ? s - 0.5f : s + 0.5f);
}

}  // namespace

uint8_t AttitudeHistory::decimation_for(float loop_hz, float span_s) {
  const float d = ceilf(loop_hz * span_s / static_cast<float>(kCapacity - 2));
  return d < 1.0f ? 1 : (d > 255.0f ? 255 : static_cast<uint8_t>(d));
}

void AttitudeHistory::push(uint32_t t_us, const Quat& q) {
  newest_push_us_ = t_us;
  if (count_ > 0 && ++skip_ < decimation_) return;
  skip_ = 0;
  Record& r = records_[head_];
  r.t_us = t_us;
  // Keep consecutive records in the same hemisphere so interpolation takes the short way.
  Quat stored = q;
  if (count_ > 0) {
    const Quat prev = unpack(at(0));
    if (negative(dot(prev, q))) stored = -q;
  }
  r.q[0] = quantise(stored.w);
  r.q[1] = quantise(stored.x);
  r.q[2] = quantise(stored.y);
  r.q[3] = quantise(stored.z);
  head_ = static_cast<uint8_t>((head_ + 1) % kCapacity);
  if (count_ < kCapacity) ++count_;
}

const AttitudeHistory::Record& AttitudeHistory::at(uint8_t age) const {
  return records_[(head_ + kCapacity - 1 - age) % kCapacity];
}

Quat AttitudeHistory::unpack(const Record& r) {
  const float k = 1.0f / 32767.0f;
  return Quat{r.q[0] * k, r.q[1] * k, r.q[2] * k, r.q[3] * k};
}

bool AttitudeHistory::lookup(uint32_t t_us, Quat& q) const {
  if (count_ == 0) return false;
  const Record& newest = at(0);
  const int32_t ahead = static_cast<int32_t>(t_us - newest.t_us);
  if (ahead >= 0) {
    // Newer than the newest record: fine up to the last push (the attitude changes little in between).
    if (static_cast<int32_t>(newest_push_us_ - t_us) < 0) return false;
    q = normalized(unpack(newest));
    return true;
  }
  for (uint8_t age = 1; age < count_; ++age) {
    const Record& older = at(age);
    const int32_t since_older = static_cast<int32_t>(t_us - older.t_us);
    if (since_older < 0) continue;
    const Record& newer = at(static_cast<uint8_t>(age - 1));
    const float span = static_cast<float>(static_cast<int32_t>(newer.t_us - older.t_us));
    const float f = span > 0.0f ? static_cast<float>(since_older) / span : 0.0f;
    // Normalised linear interpolation: within one record spacing (a few ms) it equals slerp to well
    // below the quantisation error.
    q = normalized(unpack(older) * (1.0f - f) + unpack(newer) * f);
    return true;
  }
  return false;
}

void CameraMount::configure(const Euler& e) {
  identity_ = e.roll == 0.0f && e.pitch == 0.0f && e.yaw == 0.0f;
  q_bv_ = from_euler(e);
}

void CameraMount::apply(Vec3* star_body, float q[4]) const {
  if (identity_) return;
  *star_body = rotate(q_bv_, *star_body);
  if (!star_attitude_fitted(q)) return;
  const Quat q_bs = q_bv_ * Quat{q[0], q[1], q[2], q[3]};
  q[0] = q_bs.w;
  q[1] = q_bs.x;
  q[2] = q_bs.y;
  q[3] = q_bs.z;
}

}  // namespace fw
}  // namespace quad
