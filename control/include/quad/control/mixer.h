// Motor mixing, thesis eq. 5.3-5.8: collective thrust and body torques to squared rotor speeds
// (w_bar = M^-1 T, eq. 5.8/5.9e) and on to normalised motor commands u_i = w_i / w_max in [0, 1].
// The motor order, positions and spin directions are those of quad/control/vehicle.h: the commands go
// out in that order (HIL_ACTUATOR_CONTROLS controls[0..3]).
//
// With f_i = b w_i^2, rotor i at (x_i, y_i) spinning s_i (vehicle.h), the forward model (eq. 5.5) is
//   T = sum f_i,  tau_1 = -sum y_i f_i,  tau_2 = sum x_i f_i,  tau_3 = (kappa / b) sum s_i f_i,
// which for the plus frame is exactly eq. 5.6. Its inverse for both symmetric layouts is
//   f_i = T/4 - y_i tau_1 / sum(y^2) + x_i tau_2 / sum(x^2) + s_i tau_3 b / (4 kappa).
//
// SATURATION PRIORITY (each motor's thrust must stay in [0, f_max]). A demand the motors can produce is
// reproduced exactly. Otherwise:
//   1. if thrust and roll/pitch torque fit with some part of the yaw demand, they are kept exactly and
//      yaw gets the largest part, 0..100 % (same sign), that fits: yaw is given up first, the way PX4
//      and ArduPilot desaturate;
//   2. else roll/pitch torque is kept if its motor spread fits in [0, f_max] at all (otherwise it is
//      scaled down, direction kept, until it does), the collective thrust is shifted by the least amount
//      that makes roll/pitch fit without yaw (more thrust near idle, less near full power), and yaw gets
//      the room that is left.
// So thrust goes second, and roll/pitch torque only when it alone exceeds what the motors can produce.
//
// Usage:
//   quad::ctrl::Mixer mixer(vehicle);                       // VehicleParams: frame, b, kappa, d, f_max
//   quad::ctrl::MixerOutput out = mixer.mix(thrust, tau);   // out.command[0..3] in [0, 1]
#pragma once

#include <stdint.h>

#include "quad/control/vehicle.h"
#include "quad/math/math.h"

namespace quad {
namespace ctrl {

// Collective thrust (N, along body -z) and control torques (body FRD, N m): the control vector of
// eq. 5.5.
struct Wrench {
  float thrust = 0.0f;
  Vec3 torque;
};

struct MixerOutput {
  // n_i = f_i / f_max = w_bar_i / w_bar_max in [0, 1]: eq. 5.8 per motor, in units of one motor's
  // full thrust (rotor_speed_sq() gives w_bar_i of eq. 5.7)
  float share[kMotorCount] = {0.0f, 0.0f, 0.0f, 0.0f};
  float command[kMotorCount] = {0.0f, 0.0f, 0.0f, 0.0f};         // u_i = w_i / w_max in [0, 1]
  Wrench achieved;              // what the rotor speeds produce (eq. 5.5); the demand itself when no limit acted
  bool yaw_limited = false;     // priority 3 gave up some yaw
  bool thrust_limited = false;  // priority 2 shifted the thrust
  bool roll_pitch_limited = false;  // priority 1 scaled roll/pitch torque
};

class Mixer {
 public:
  Mixer();
  explicit Mixer(const VehicleParams& v);
  // Leaves the coefficients unset, for an owner that calls set_vehicle() before any use (Cascade, whose
  // configure() always ends with a valid vehicle): saves computing the defaults twice, and their code.
  struct Unset {};
  explicit Mixer(Unset) {}

  // Precomputes the inverse mixing coefficients; call when the vehicle parameters change.
  void set_vehicle(const VehicleParams& v);

  // Mixes a demand with the saturation priority above. Non-finite input gives all motors 0 (and every
  // limited flag set).
  MixerOutput mix(float thrust, const Vec3& torque) const;
  MixerOutput mix(const Wrench& w) const { return mix(w.thrust, w.torque); }
  // The same into `out` (every field written): no copy of the result (Cascade).
  void mix(float thrust, const Vec3& torque, MixerOutput& out) const;

  // The forward model eq. 5.5: thrust and torques from the motors' thrust shares (MixerOutput::share).
  Wrench forward(const float share[kMotorCount]) const;
  // w_bar_i of eq. 5.7, (rad/s)^2, for a thrust share n_i (not on the flight path: the firmware commands
  // the motors by u_i = sqrt(n_i)).
  float rotor_speed_sq(float share) const { return share * w_sq_max_; }

 private:
  bool spread(float c, const float rp[kMotorCount], float yaw, float f[kMotorCount]) const;
  bool fit_yaw(float c, const float rp[kMotorCount], float yaw, float f[kMotorCount], float& step) const;

  // (No member initialisers: set_vehicle() sets them all, and every constructor but the Unset one calls it.)
  // Everything below is in normalised motor thrust n_i = f_i / f_max, so the range check is [0, 1]
  // (done on the bit patterns, no float comparison) and the command is sqrt(n_i) with no scaling.
  float collective_gain_;  // 1 / (4 f_max): n_i share of the collective thrust per newton
  float thrust_full_;      // 4 f_max: collective share back to newtons (thrust shifted)
  float w_sq_max_;         // f_max / b: n_i to w_bar_i (eq. 5.7)
  float yaw_torque_;       // N m per unit of the yaw share (the inverse of yaw_gain_ times f_max)
  // Inverse (eq. 5.8): every nonzero entry of a column of M^-1 has the same magnitude, so a column is a
  // gain and a sign per motor (-1, 0, +1), and mixing needs three multiplications, not twelve. The
  // gains are per f_max (normalised thrust per N m).
  float roll_gain_;
  float pitch_gain_;
  float yaw_gain_;
  int8_t roll_sign_[kMotorCount];
  int8_t pitch_sign_[kMotorCount];
  int8_t yaw_sign_[kMotorCount];
};

}  // namespace ctrl
}  // namespace quad
