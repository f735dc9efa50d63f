#include "quad/control/mixer.h"

namespace quad {
namespace ctrl {

namespace {
constexpr float kRoundOff = 1e-6f;
}  // namespace

Mixer::Mixer() { set_vehicle(VehicleParams{}); }

Mixer::Mixer(const VehicleParams& v) { set_vehicle(v); }

void Mixer::set_vehicle(const VehicleParams& v) {
  b_ = v.thrust_coeff;
  inv_b_ = 1.0f / v.thrust_coeff;
  f_max_ = v.max_motor_thrust;
  inv_f_max_ = 1.0f / v.max_motor_thrust;
  const float yaw_per_thrust = v.yaw_coeff / v.thrust_coeff;  // kappa / b, m
  float roll_sq = 0.0f, pitch_sq = 0.0f, yaw_sq = 0.0f;
  for (int i = 0; i < kMotorCount; ++i) {
    const MotorLayout m = motor_layout(v.frame, v.arm_length, i);
    // Forward factors, thesis eq. 5.4/5.6 in per-rotor form: the thrust f_i along body -z at (x_i, y_i)
    // gives the torque (x_i, y_i, 0) x (0, 0, -f_i) = (-y_i f_i, x_i f_i, 0), plus the drag torque.
    roll_arm_[i] = -m.y;
    pitch_arm_[i] = m.x;
    yaw_arm_[i] = m.spin * yaw_per_thrust;
    roll_sq += roll_arm_[i] * roll_arm_[i];
    pitch_sq += pitch_arm_[i] * pitch_arm_[i];
    yaw_sq += yaw_arm_[i] * yaw_arm_[i];
  }
  // Inverse, thesis eq. 5.8: the four columns of the forward map (thrust, roll, pitch, yaw) are
  // mutually orthogonal for both layouts, so each row of M^-1 is a column divided by its squared norm.
  // For the plus frame this gives exactly the entries (4b)^-1, (2db)^-1, (4 kappa)^-1 of eq. 5.8
  // (here in thrust units: f_i = b w_bar_i).
  for (int i = 0; i < kMotorCount; ++i) {
    roll_mix_[i] = roll_arm_[i] / roll_sq;
    pitch_mix_[i] = pitch_arm_[i] / pitch_sq;
    yaw_mix_[i] = yaw_arm_[i] / yaw_sq;
  }
}

// The largest yaw fraction lambda in [0, 1] with 0 <= c + rp_i + lambda yaw_i <= f_max on every motor.
// Each motor bounds lambda to an interval; returns false if their intersection with [0, 1] is empty.
// The yaw column sums to zero and is orthogonal to roll and pitch, so lambda changes nothing else.
bool Mixer::max_yaw_scale(float collective, const float rp[kMotorCount], const float yaw[kMotorCount],
                          float& scale) const {
  float lo = 0.0f, hi = 1.0f;
  for (int i = 0; i < kMotorCount; ++i) {
    const float base = collective + rp[i];
    const float room_down = -base;          // lambda yaw_i >= -base
    const float room_up = f_max_ - base;    // lambda yaw_i <= f_max - base
    if (yaw[i] > 0.0f) {
      lo = maxf(lo, room_down / yaw[i]);
      hi = minf(hi, room_up / yaw[i]);
    } else if (yaw[i] < 0.0f) {
      lo = maxf(lo, room_up / yaw[i]);
      hi = minf(hi, room_down / yaw[i]);
    } else if (base < -kRoundOff * f_max_ || base > (1.0f + kRoundOff) * f_max_) {
      return false;
    }
  }
  // A relative slack of a few float epsilons keeps round-off from declaring a feasible demand infeasible.
  if (lo > hi + kRoundOff) return false;
  scale = maxf(hi, 0.0f);
  return true;
}

MixerOutput Mixer::mix(float thrust, const Vec3& torque) const {
  MixerOutput out;
  if (!is_finite(thrust) || !is_finite(torque)) {
    out.yaw_limited = out.thrust_limited = out.roll_pitch_limited = true;
    return out;  // all motors at zero
  }

  // Per-motor thrust shares of the demand (eq. 5.8): f_i = c + rp_i + lambda yaw_i, with the collective
  // share c = T/4 and lambda = 1 when nothing saturates.
  float rp[kMotorCount];
  float yaw[kMotorCount];
  for (int i = 0; i < kMotorCount; ++i) {
    rp[i] = roll_mix_[i] * torque.x + pitch_mix_[i] * torque.y;
    yaw[i] = yaw_mix_[i] * torque.z;
  }

  float collective = 0.25f * thrust;
  float yaw_scale = 0.0f;
  if (!max_yaw_scale(collective, rp, yaw, yaw_scale)) {
    // Thrust with roll/pitch does not fit for any yaw fraction in [0, 1].
    float rp_lo = rp[0], rp_hi = rp[0];
    for (int i = 1; i < kMotorCount; ++i) {
      rp_lo = minf(rp_lo, rp[i]);
      rp_hi = maxf(rp_hi, rp[i]);
    }
    // Priority 1: roll/pitch alone must fit between 0 and f_max on every motor.
    const float spread = rp_hi - rp_lo;
    if (spread > f_max_) {
      const float s = f_max_ / spread;
      for (int i = 0; i < kMotorCount; ++i) rp[i] *= s;
      rp_lo *= s;
      rp_hi *= s;
      out.roll_pitch_limited = true;
    }
    // Priority 2: shift the collective share as little as possible so that roll/pitch fit (without
    // yaw); priority 3: then whatever yaw fits in the room left.
    collective = clampf(collective, -rp_lo, f_max_ - rp_hi);
    out.thrust_limited = true;
    if (!max_yaw_scale(collective, rp, yaw, yaw_scale)) yaw_scale = 0.0f;
  }
  out.yaw_limited = yaw_scale < 1.0f;

  for (int i = 0; i < kMotorCount; ++i) {
    // Clamp only absorbs round-off here: every term was chosen to fit.
    const float f = clampf(collective + rp[i] + yaw_scale * yaw[i], 0.0f, f_max_);
    out.rotor_speed_sq[i] = f * inv_b_;           // w_bar_i of eq. 5.7
    out.command[i] = sqrtf(f * inv_f_max_);      // u_i = w_i / w_max (vehicle.h motor model)
  }
  out.achieved = forward(out.rotor_speed_sq);
  return out;
}

Wrench Mixer::forward(const float rotor_speed_sq[kMotorCount]) const {
  // thesis eq. 5.5: (T, tau) = M w_bar, evaluated per rotor with f_i = b w_bar_i (eq. 5.3).
  Wrench w;
  for (int i = 0; i < kMotorCount; ++i) {
    const float f = b_ * rotor_speed_sq[i];
    w.thrust += f;
    w.torque.x += roll_arm_[i] * f;
    w.torque.y += pitch_arm_[i] * f;
    w.torque.z += yaw_arm_[i] * f;
  }
  return w;
}

}  // namespace ctrl
}  // namespace quad
