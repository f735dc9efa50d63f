// Position trim: removes the steady offsets of the position controller, one integrator per NED axis.
//
// Thesis eq. 8.20 is a PD law, mu_d = a_d - K_p tanh(p - p_d) - K_v tanh(v - v_d), so any constant
// acceleration the controller does not know about leaves a constant position error of about
// disturbance / K_p:
//   - vertically, a mismatch between the thrust the controller believes it commands and the thrust the
//     vehicle makes (mass, motor curve, battery sag: about 2 % in HIL) gives g * mismatch / K_p,z (6 cm
//     in HIL, 13.5 cm for a 5 % heavier vehicle);
//   - horizontally, the accelerometer bias the attitude observer takes for tilt (0.3 deg, 0.05 m/s^2,
//     after a minute of the MPU-6000's bias random walk: the attitude controller then holds a true tilt,
//     g tan 0.3 deg / K_p = 1.4 cm), a weak motor (its torque is held by a steady tilt: 44 cm in HIL for
//     20 % efficiency lost), a centre of mass off the middle.
// This adds the missing integral action outside the control library, as an acceleration feed-forward
// on a_d:
//   a_trim,i = -K_i,i * integral of clamp(p_i - p_d,i, +-0.2 m) dt,   clamped to |a_trim,i| <= limit_i
//   (anti-windup: a large error is a transient and is learned at most at the 0.2 m rate; the integral
//   stops growing at the limit)
// With table 8.1's K_p = 3.625 the loop s^3 + K_v s^2 + K_p s + K_i stays stable for K_i < K_v K_p
// (Routh): 12.7 vertically (K_v,z = 3.5), 43 horizontally (K_v,xy = 11.875). POS_KI_Z = 1 puts the
// vertical poles at -0.44, -1.29 and -1.78 1/s (time constant about 2.3 s); docs/firmware.md gives the
// horizontal choice. The caller runs it only while airborne in AUTO (on the ground the error means
// nothing) and freezes an axis while the shaped setpoint moves along it (the tracking lag of a move is
// not an offset to learn: it would wind up and overshoot); it starts from zero at arming.
#pragma once

#include "quad/math/math.h"

namespace quad {
namespace fw {

// One axis: the integrator itself (its gain and limit are the caller's, so the axes that share them
// store them once: RAM is the ATmega2560's scarcest resource).
class AxisTrim {
 public:
  // m: errors beyond this are integrated as this (a transient, not an offset; see update()).
  static constexpr float kMaxLearnedError = 0.2f;

  void reset() { accel_ = 0.0f; }
  // Clamps the held value into a (new) limit.
  void clamp(float limit);
  // One step with the position error p_i - p_d,i (NED, m) over dt seconds, gain ki (1/s^2 per m, 0:
  // held), limit in m/s^2.
  void update(float position_error, float dt, float ki, float limit);
  // The same for a dt already known to be > 0 (PositionTrim tests it once for the three axes).
  void learn(float position_error, float dt, float ki, float limit);

  // The acceleration feed-forward to add to a_d,i (NED, m/s^2; on z negative = more thrust).
  float accel() const { return accel_; }

 private:
  float accel_ = 0.0f;
};

// The three axes, x and y with one gain and limit (POS_KI_XY, POS_I_MAX_XY), z with its own (POS_KI_Z,
// POS_I_MAX_Z).
class PositionTrim {
 public:
  void configure(float ki_xy, float limit_xy, float ki_z, float limit_z);
  void reset();
  // learn[i] false freezes axis i (held, not reset).
  void update(const Vec3& position_error, const bool learn[3], float dt);
  Vec3 accel() const { return {axis_[0].accel(), axis_[1].accel(), axis_[2].accel()}; }
  float accel_z() const { return axis_[2].accel(); }

 private:
  float ki_[2] = {0.0f, 0.0f};     // horizontal, vertical
  float limit_[2] = {0.0f, 0.0f};
  AxisTrim axis_[3];
};

}  // namespace fw
}  // namespace quad
