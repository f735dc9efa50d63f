// Manual (RC) flight, thesis sec. 6.1.4: stick pulses (1000-2000 us, mid 1500) to a desired attitude
// and thrust.
//   roll, pitch stick -> desired roll / pitch angle, linear up to max_angle at full deflection;
//   yaw stick         -> yaw rate, integrated into the desired heading (releasing the stick holds it);
//   throttle          -> collective thrust, linear from 0 at 1000 us to max_thrust at 2000 us;
//   Q_d from roll, pitch and heading by thesis eq. 6.2 (ZYX Euler angles to quaternion).
// A dead band around mid stick gives exactly zero. Stick directions (ArduPilot's mode-2 convention):
// roll stick right (> 1500) rolls right side down; pitch stick pulled back (> 1500) pitches nose up,
// pushed forward (< 1500) pitches nose down; yaw stick right (> 1500) turns the nose right (clockwise
// seen from above). A channel wired the other way is flipped with the reverse flags.
// Pulses outside [min_pulse, max_pulse] are treated as a failed receiver: update() returns false and
// holds the previous output (the firmware's failsafe decides what to do).
//
// The trigonometry is cheap: the half angles of roll and pitch (<= 45 deg) use sincos_small(), and the
// heading is kept as the unit pair (cos psi/2, sin psi/2), turned by a small rotation every step.
//
// Usage:
//   quad::ctrl::ManualControl manual;            // defaults: 30 deg, 90 deg/s, Quad-C thrust range
//   manual.reset(current_yaw);                   // when entering manual mode: hold the present heading
//   quad::ctrl::RcSticks rc{roll_us, pitch_us, yaw_us, throttle_us};
//   if (manual.update(rc, dt)) { cmd = manual.command(); }   // cmd.thrust, cmd.q_d
#pragma once

#include <stdint.h>

#include "quad/control/thrust_attitude.h"
#include "quad/math/math.h"

namespace quad {
namespace ctrl {

// Pulse widths from the receiver, microseconds.
struct RcSticks {
  uint16_t roll = 1500;
  uint16_t pitch = 1500;
  uint16_t yaw = 1500;
  uint16_t throttle = 1000;
};

struct ManualParams {
  float max_angle = 30.0f * kDegToRad;     // roll / pitch at full stick, rad (<= 45 deg)
  float max_yaw_rate = 90.0f * kDegToRad;  // rad/s at full yaw stick
  float max_thrust = 4.0f * 0.880f * kGravity;  // N at full throttle
  uint16_t dead_band = 20;                 // us either side of mid stick that read as zero
  uint16_t min_pulse = 900;                // outside [min_pulse, max_pulse]: receiver failure
  uint16_t max_pulse = 2100;
  bool reverse_roll = false;
  bool reverse_pitch = false;
  bool reverse_yaw = false;
};

class ManualControl {
 public:
  ManualControl() { set_params(ManualParams{}); }
  explicit ManualControl(const ManualParams& p) { set_params(p); }

  void set_params(const ManualParams& p);
  const ManualParams& params() const { return params_; }

  // Sets the held heading (rad), e.g. to the estimated yaw when manual flight starts.
  void reset(float yaw);

  // One step of dt seconds. Returns false (and keeps the previous command) on an implausible pulse.
  bool update(const RcSticks& rc, float dt);

  const AttitudeCommand& command() const { return command_; }
  float heading() const;  // the held heading, rad in (-pi, pi]

 private:
  ManualParams params_;
  float stick_scale_ = 0.0f;  // 1 / (500 us - dead band), precomputed: no division in the loop
  float yaw_half_c_ = 1.0f;  // (cos, sin) of half the held heading
  float yaw_half_s_ = 0.0f;
  AttitudeCommand command_;
};

// Stick pulse to [-1, 1]: 0 inside mid +- dead_band, linear to +-1 at 1000 / 2000 us, clamped.
float stick_to_unit(uint16_t pulse_us, uint16_t dead_band);

// Throttle pulse to [0, 1]: 0 at or below 1000 us, 1 at or above 2000 us.
float throttle_to_unit(uint16_t pulse_us);

// Returns nullptr when usable, else the name of the first bad field.
const char* validate(const ManualParams& p);

}  // namespace ctrl
}  // namespace quad
