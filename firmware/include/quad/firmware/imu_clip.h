// IMU clipping guard: keeps readings at the sensor's full scale out of the estimator.
//
// A reading pinned at the end of the range (a shock, a spin past the range) says only "at least this
// much": integrating it as the rate turns the attitude estimate by range * duration (2000 deg/s for
// 30 ms = 60 deg), and as a specific force it pushes the position filter by metres per second. Like the
// mature autopilots (PX4 counts a sample at the ADC's limit as clipped, ArduPilot near 97 % of it), an
// axis counts as clipped from kClipFraction of the configured range (IMU_GYRO_RANGE, IMU_ACC_RANGE).
//
// For each sample the guard gives the gyro to integrate: a clipped axis is replaced by its last good
// value while the IMU has been clipping for at most hold_s (IMU_CLIP_HOLD); beyond that the guard is
// unhealthy (the application's estimator-unhealthy failsafe lands) and the reading passes unchanged (a
// rate clipped that long is a real rotation at least that fast: full scale is the better guess). A
// clipped accelerometer is only flagged: the caller drops the gravity correction and the position
// filter's prediction input for that sample. Non-finite values are not clipping; they pass unchanged
// to the observer's own checks.
#pragma once

#include <stdint.h>

#include "quad/hal/hal.h"
#include "quad/math/math.h"

namespace quad {
namespace fw {

class ImuClipGuard {
 public:
  // An axis at or beyond this fraction of full scale is clipped: the MPU-6000's 16-bit register tops
  // out one LSB below the range, and behind its low-pass filter a clipped input approaches it from
  // below; 1 % of the range (20 deg/s, 0.08 g) is far above the sensor noise.
  static constexpr float kClipFraction = 0.99f;
  // A burst is a run of clipped samples with less than this between them: one STATUSTEXT per burst,
  // however hard the frame vibrates.
  static constexpr float kBurstGapS = 1.0f;

  // gyro_range rad/s, accel_range m/s^2 (both > 0), hold_s >= 0. Keeps the counters and the state.
  void configure(float gyro_range, float accel_range, float hold_s);

  // One raw sample, dt > 0 seconds after the previous one. Returns the gyro to integrate (see above).
  Vec3 update(const hal::ImuSample& raw, float dt);

  bool gyro_clipped() const { return gyro_clipped_; }    // this sample has a clipped gyro axis
  bool accel_clipped() const { return accel_clipped_; }  // this sample has a clipped accel axis
  // This sample begins a burst: the first clipped sample after kBurstGapS without clipping.
  bool burst_started() const { return burst_started_; }
  // False while some axis has been clipping for longer than hold_s.
  bool healthy() const { return clipping_for_s_ <= hold_s_; }

  uint32_t clipped_samples() const { return clipped_samples_; }
  uint32_t bursts() const { return bursts_; }

 private:
  // kClipFraction * range (+0 for one not above zero): a reading with |x| at or above it is clipped.
  float gyro_limit_ = 0.0f;
  float accel_limit_ = 0.0f;
  float hold_s_ = 0.0f;
  Vec3 last_good_gyro_;
  float clipping_for_s_ = 0.0f;  // since the last sample with no clipped axis
  float quiet_for_s_ = kBurstGapS;  // since the last clipped sample
  bool gyro_clipped_ = false;
  bool accel_clipped_ = false;
  bool burst_started_ = false;
  uint32_t clipped_samples_ = 0;
  uint32_t bursts_ = 0;
};

}  // namespace fw
}  // namespace quad
