// The EKF of quad/estimation/ekf.h run behind the present, so that the station's fixes, which arrive
// tens of milliseconds after their images were captured, are fused at their capture time.
//
// Usage:
//   quad::est::DelayedEkf<quad::est::history_length(100)> ekf;   // 250 ms of increments at 100 Hz
//   ekf.set_params(p, 0.1f);                      // the filter runs 100 ms behind now
//   ekf.reset(q0, gyro_bias, accel_bias, t_us);   // after the boot calibration; position unknown
//   every IMU sample:     ekf.imu(gyro_frd, accel_frd, dt);
//   magnetometer sample:  ekf.mag(mag_frd);
//   at the predict rate:  ekf.predict(t_us, on_ground_and_still, hovering_still, on_the_floor);
//   a fix arrives:        ekf.queue_fix(fix);  its covariance:  ekf.attach_covariance(...)
//   ekf.attitude(), position(), velocity(), rate()
//
// How (the delayed fusion horizon of PX4's ECL, with exact re-propagation of the state): every predict
// pushes the IMU increments since the last one (delta angle, delta velocity, the magnetometer sample, the
// still flag) into a ring buffer. The filter proper (state and covariance) runs `delay` behind the newest
// increment: it takes the increments that have come of age one by one, and after each fuses the fixes
// captured within it (the fix moved by the filter's rates to the increment's end, at most one step).
// The present state (the output) is the filter's state carried through the younger increments by the
// nominal model alone, recomputed at every predict, and carried sample by sample in between. The
// covariance never goes back in time: one prediction per predict call, one update per fix.
//
// Memory (Cortex-M4F, float): filter 900 B of covariance + 64 B of state; per increment 48 B
// (history_length(100) = 26 entries: 1 248 B); fix queue 8 x 84 B. Fixes captured before the filter's
// time when they arrive (older than `delay`) are refused as too old.
#pragma once

#include <stdint.h>

#include "quad/estimation/ekf.h"

namespace quad {
namespace est {

struct ImuIncrement {
  uint32_t t_us = 0;  // end of the interval
  float dt = 0.0f;
  Vec3 delta_angle;
  Vec3 delta_velocity;  // in the body frame at the start of the interval
  Vec3 mag;
  bool has_mag = false;
  bool still = false;
  bool on_floor = false;  // still, standing on the floor set_floor() gives
  bool hovering = false;
};

enum class EkfFixResult : uint8_t { kQueued, kRejectedTooOld, kRejectedOutOfOrder, kRejectedInvalid, kRejectedBusy };

struct DelayedEkfHealth {
  uint32_t positions_fused = 0;
  uint32_t attitudes_fused = 0;
  uint32_t positions_rejected = 0;  // gate
  uint32_t attitudes_rejected = 0;  // gate
  uint32_t headings_fused = 0;
  uint32_t headings_rejected = 0;
  uint32_t hover_forces_fused = 0;
  uint32_t fixes_too_old = 0;
  uint32_t fixes_refused = 0;      // out of order, invalid, queue full
  uint32_t resets = 0;             // position set from a fix (first, lost, or after rejections)
};

// ESTIMATOR_STATUS flags (MAVLink ESTIMATOR_STATUS_FLAGS, the bits PX4 sets for a local-position
// estimator; docs/estimation.md, "Health report").
enum EstimatorFlag : uint16_t {
  kEstAttitude = 1,
  kEstVelocityHoriz = 2,
  kEstVelocityVert = 4,
  kEstPosHorizRel = 8,
  kEstPosVertAbs = 32,
  kEstConstPosMode = 128,
  kEstPredPosHorizRel = 256,
  kEstAccelError = 2048,
};

// The attitude counts as good (ESTIMATOR_STATUS, the pre-arm check) with the tilt's sigma within this.
constexpr float kGoodTiltSigma = 0.0175f;  // rad (1 deg)
// The position counts as aided while a fix was fused within this of the filter's time.
constexpr uint32_t kAidedWindowUs = 250000;

class DelayedEkfCore {
 public:
  static constexpr int kFixQueue = 8;

  // delay_s: how far behind the newest increment the filter runs (the largest fix delay it accepts).
  // use_hover_force: fuse the hovering specific force as the accelerometer's bias (predict's hovering).
  void set_params(const EkfParams& p, float delay_s, bool use_mag, bool use_hover_force = false);
  const EkfParams& params() const { return filter_.params(); }
  // Attitude and biases from the boot calibration; velocity zero, position unknown until the first fix.
  void reset(const Quat& q, const Vec3& gyro_bias, const Vec3& accel_bias, uint32_t t_us);
  bool started() const { return started_; }

  void imu(const Vec3& gyro, const Vec3& accel, float dt);
  void mag(const Vec3& field);
  // still: on the ground and still (zero velocity, and the position where it came to rest held);
  // hovering: hovering still in flight (the step's horizontal specific force is the accelerometer's
  // bias); on_floor: still on the floor of set_floor() (its height is the held position's down).
  void predict(uint32_t t_us, bool still, bool hovering = false, bool on_floor = false);
  // The down coordinate of the reference point standing on the floor (the star's floor less the
  // vehicle's standing height), m NED.
  void set_floor(float down) { floor_down_ = down; }

  EkfFixResult queue_fix(const StarFix& fix);
  // The station's covariances for the queued fix captured at capture_us (LANDING_TARGET_COVARIANCE);
  // false when no such fix waits.
  bool attach_covariance(uint32_t capture_us, const float pos_cov[6], const float att_cov[6], bool attitude_valid);
  uint8_t fixes_waiting() const { return fix_count_; }

  Quat attitude() const { return out_.q; }
  Vec3 position() const { return out_.p; }
  Vec3 velocity() const { return out_.v; }
  Vec3 rate() const { return rate_; }
  const EkfState& delayed_state() const { return filter_.state(); }
  const ErrorStateEkf& filter() const { return filter_; }
  uint32_t filter_time_us() const { return filter_us_; }
  bool position_initialized() const { return position_initialized_; }
  const DelayedEkfHealth& health() const { return health_; }
  // Attitude and velocity settled once since the reset (the pre-arm check): tilt sigma <= 1 deg and
  // velocity sigma <= 0.1 m/s at some predict (latched: in flight without fixes the velocity's grows).
  bool converged() const { return converged_ && finite(); }
  bool settled() const;
  bool finite() const;
  // ESTIMATOR_STATUS flags as PX4's EKF2 sets them for its aiding sources: attitude (tilt sigma within
  // kGoodTiltSigma); horizontal position, both velocities, vertical position and the predicted
  // position while fixes are fused (one within kAidedWindowUs); the velocities, the vertical position
  // while standing still (zero velocity fused in the newest step taken), constant-position mode when
  // standing still without fixes; only kEstAccelError when the filter is not finite.
  uint16_t flags() const;

 protected:
  DelayedEkfCore(ImuIncrement* storage, uint16_t capacity) : buffer_(storage), capacity_(capacity) {}
  DelayedEkfCore(const DelayedEkfCore&) = delete;
  DelayedEkfCore& operator=(const DelayedEkfCore&) = delete;

 private:
  const ImuIncrement& entry(uint16_t age_from_oldest) const;
  void advance(const ImuIncrement& e);
  void fuse_due_fixes(const ImuIncrement& e);
  void fuse_fix(StarFix fix, const ImuIncrement& e);
  void recompute_output();
  // Standing still: the held position (set at the first still increment; the floor's height on the
  // floor), then zero velocity.
  void fuse_ground(const ImuIncrement& e);
  // A fix's position was fused within kAidedWindowUs before t_us.
  bool aided(uint32_t t_us) const;
  // Without fixes (none fused within the window, none waiting), nothing stands below the floor: the
  // filter's and the output's down position are kept above it, so a dead-reckoned touchdown ends on it.
  bool floor_applies() const;
  // The output (the present) projected onto the floor when floor_applies().
  void keep_output_above_floor();
  void clear_accumulator();

  ErrorStateEkf filter_;
  EkfState out_;
  Vec3 rate_;
  uint32_t delay_us_ = 100000;
  bool use_mag_ = true;
  bool use_hover_force_ = false;
  bool started_ = false;
  bool position_initialized_ = false;
  bool converged_ = false;
  bool still_ = false;             // the newest increment the filter took fused zero velocity
  Vec3 hold_;                      // the position held while still (valid while still_)
  float floor_down_ = NAN;         // set_floor() (NaN: no floor)
  bool fix_fused_ = false;         // a fix's position was fused (or set the position) at fix_fused_us_
  uint32_t fix_fused_us_ = 0;
  uint16_t rejections_in_a_row_ = 0;
  uint32_t filter_us_ = 0;
  uint32_t last_push_us_ = 0;
  // The increment being accumulated.
  Quat acc_rotation_;
  ImuIncrement acc_;
  // Ring of increments.
  ImuIncrement* buffer_;
  uint16_t capacity_;
  uint16_t head_ = 0;
  uint16_t count_ = 0;
  // Fixes waiting for the filter to reach their capture time, in capture order.
  StarFix fixes_[kFixQueue];
  uint8_t fix_head_ = 0;
  uint8_t fix_count_ = 0;
  DelayedEkfHealth health_;
};

template <int kHistory>
class DelayedEkf : public DelayedEkfCore {
  static_assert(kHistory >= 2 && kHistory <= 65535, "the buffer needs at least two increments");

 public:
  DelayedEkf() : DelayedEkfCore(storage_, static_cast<uint16_t>(kHistory)) {}

 private:
  ImuIncrement storage_[kHistory];
};

}  // namespace est
}  // namespace quad
