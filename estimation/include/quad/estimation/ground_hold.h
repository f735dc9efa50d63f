// Ground state: whether the vehicle stands still on the ground, and the position it stands at, for
// whichever position estimator the image runs (the per-axis Kalman filter: PositionFilterCore::fuse_still).
//
// Usage:
//   quad::est::GroundHold ground;
//   ground.configure(quad::est::GroundHoldParams{});
//   once per filter step, with the bias-corrected gyro and mean specific force (FRD) over dt seconds:
//     if (ground.update(landed_or_disarmed, gyro, accel, dt)) {
//       if (ground.started()) ground.set_reference(estimate);   // the last known position
//       kf.fuse_still(ground.reference(), ...);
//     } else if (ground.at_rest()) {
//       kf.fuse_zero_velocity(...);                            // touched down: stop at once
//     }
//
// Why: without vision (the cameras see only a patch of the star once they are close to the floor) the
// filter dead-reckons on the accelerometer, and a residual bias or tilt error of a few cm/s^2 runs the
// estimate away by metres in a minute while the vehicle sits still. On the ground and still, the
// vehicle's velocity is zero and its position is where it came to rest: both are measurements the filter
// can fuse (pseudo-measurements, as PX4's EKF2 and ArduPilot's EKF3 fuse zero velocity and the last known
// position on the ground without aiding).
//
// "On the ground" is the caller's (the land detector, or disarmed); "still" is this unit's: the gyro's
// rate below gyro_max and the specific force's magnitude within accel_max of g, on the ground, for
// still_time_s without a break (a steady descent is as still as standing to an IMU). A quadrotor the land detector takes for landed but that still flies (less than hover thrust) is
// accelerating downwards, |a| < g, so it is not still; one that is carried or bumped is not still either.
#pragma once

#include "quad/math/float_bits.h"
#include "quad/math/math.h"

namespace quad {
namespace est {

struct GroundHoldParams {
  float gyro_max = 0.1f;      // rad/s: |omega| below this is still
  float accel_max = 0.5f;     // m/s^2: ||a| - g| below this is still
  float still_time_s = 0.5f;  // s without a break before the hold begins
};

class GroundHold {
 public:
  void configure(const GroundHoldParams& p);

  // One step of dt seconds: on_ground from the caller, gyro (rad/s) and specific force (m/s^2, FRD) with
  // the calibrated biases removed. Returns holding().
  bool update(bool on_ground, const Vec3& gyro, const Vec3& accel, float dt);

  // On the ground and still: the position is to be held.
  bool holding() const { return holding_; }
  // The hold began in the last update(): the caller sets the reference (the last known position).
  bool started() const { return started_; }
  // Still, on the ground, for the still time.
  bool still() const { return still_for_s_ >= still_time_s_; }
  // On the ground and still in this step, the still time not yet passed: the vehicle has come to rest
  // (touched down) and its velocity is zero; the position is held once the still time has passed.
  bool at_rest() const { return positive(still_for_s_) && !holding_; }  // (every prediction: on the bits)

  void set_reference(const Vec3& p) { reference_ = p; }
  const Vec3& reference() const { return reference_; }

 private:
  // Squared bounds: |omega|^2 < gyro_max^2 and (g - accel_max)^2 < |a|^2 < (g + accel_max)^2, so no
  // square root per step.
  float gyro_max2_ = 0.01f;
  float accel_lo2_ = 0.0f;
  float accel_hi2_ = 0.0f;
  float still_time_s_ = 0.5f;
  float still_for_s_ = 0.0f;
  bool holding_ = false;
  bool started_ = false;
  Vec3 reference_;
};

}  // namespace est
}  // namespace quad
