#include "quad/control/mixer.h"

namespace quad {
namespace ctrl {

namespace {

constexpr float kRoundOff = 1e-6f;

// -1, 0 or +1: zero when |x| is negligible against the scale (the plus frame's zero arms).
int8_t sign_of(float x, float scale) {
  if (absf(x) < 1e-6f * scale) return 0;
  return x > 0.0f ? 1 : -1;
}

// sign * g and x + sign * g without a multiplication (float multiplications are software on the AVR).
float signed_term(int8_t sign, float g) { return sign > 0 ? g : (sign < 0 ? -g : 0.0f); }
float add_signed(float x, int8_t sign, float g) { return sign > 0 ? x + g : (sign < 0 ? x - g : x); }

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
  // (here in thrust units: f_i = b w_bar_i). Within a column the nonzero entries differ only in sign.
  roll_gain_ = pitch_gain_ = yaw_gain_ = 0.0f;
  for (int i = 0; i < kMotorCount; ++i) {
    roll_gain_ = maxf(roll_gain_, absf(roll_arm_[i]) / roll_sq);
    pitch_gain_ = maxf(pitch_gain_, absf(pitch_arm_[i]) / pitch_sq);
    yaw_gain_ = maxf(yaw_gain_, absf(yaw_arm_[i]) / yaw_sq);
  }
  for (int i = 0; i < kMotorCount; ++i) {
    roll_sign_[i] = sign_of(roll_arm_[i], v.arm_length);
    pitch_sign_[i] = sign_of(pitch_arm_[i], v.arm_length);
    yaw_sign_[i] = sign_of(yaw_arm_[i], yaw_per_thrust);
  }
}

// The largest yaw fraction lambda in [0, 1] with 0 <= base_i + lambda yaw_i <= f_max on every motor, where
// base_i = c + rp_i and yaw_i = s_i yaw_share (s_i the yaw column's sign, -1/0/+1); false if there is
// none. Only a motor that is out of range at lambda = 1 can bound lambda below 1; every yaw_i has the
// magnitude |yaw_share|, so one reciprocal serves all such motors. The yaw column sums to zero and is
// orthogonal to roll and pitch, so lambda changes neither thrust nor roll/pitch torque.
bool Mixer::max_yaw_scale(const float base[kMotorCount], float yaw_share, float& scale, float f[kMotorCount]) const {
  float hi = 1.0f;
  float inv_abs_yaw = 0.0f;  // 1 / |yaw_share|, computed when first needed
  for (int i = 0; i < kMotorCount; ++i) {
    const float y = signed_term(yaw_sign_[i], yaw_share);
    const float full = base[i] + y;
    const bool over = full > f_max_ && y > 0.0f;
    const bool under = full < 0.0f && y < 0.0f;
    if (!over && !under) continue;
    // (The floor keeps the reciprocal finite for a denormal yaw share.)
    if (inv_abs_yaw == 0.0f) inv_abs_yaw = 1.0f / maxf(absf(yaw_share), 1e-30f);
    // (f_max - base) / y above the range, -base / y below it.
    hi = minf(hi, (over ? f_max_ - base[i] : base[i]) * inv_abs_yaw);
  }
  hi = maxf(hi, 0.0f);
  // A relative slack of a few float epsilons keeps round-off from declaring a feasible demand infeasible.
  const float slack = kRoundOff * f_max_;
  const float step = hi * yaw_share;
  for (int i = 0; i < kMotorCount; ++i) {
    const float fi = add_signed(base[i], yaw_sign_[i], step);
    if (fi < -slack || fi > f_max_ + slack) return false;
    f[i] = clampf(fi, 0.0f, f_max_);  // the clamp only absorbs that round-off
  }
  scale = hi;
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
  const float roll = roll_gain_ * torque.x;
  const float pitch = pitch_gain_ * torque.y;
  const float yaw_share = yaw_gain_ * torque.z;
  float rp[kMotorCount];
  float base[kMotorCount];  // c + rp_i
  float f[kMotorCount];
  const float wanted = 0.25f * thrust;
  bool fits = true;  // the common case, decided without a division
  for (int i = 0; i < kMotorCount; ++i) {
    // (On the plus frame each motor has only a roll or only a pitch arm: no addition.)
    rp[i] = roll_sign_[i] == 0 ? signed_term(pitch_sign_[i], pitch)
                               : add_signed(signed_term(roll_sign_[i], roll), pitch_sign_[i], pitch);
    base[i] = wanted + rp[i];
    f[i] = add_signed(base[i], yaw_sign_[i], yaw_share);
    fits = fits && f[i] >= 0.0f && f[i] <= f_max_;
  }

  if (!fits) {
    float collective = wanted;
    float rp_scale = 1.0f;
    float yaw_scale = 1.0f;
    if (!max_yaw_scale(base, yaw_share, yaw_scale, f)) {
      // Thrust with roll/pitch does not fit for any yaw fraction in [0, 1].
      float rp_lo = rp[0], rp_hi = rp[0];
      for (int i = 1; i < kMotorCount; ++i) {
        rp_lo = minf(rp_lo, rp[i]);
        rp_hi = maxf(rp_hi, rp[i]);
      }
      // Priority 1: roll/pitch alone must fit between 0 and f_max on every motor.
      const float spread = rp_hi - rp_lo;
      if (spread > f_max_) {
        rp_scale = f_max_ / spread;
        for (int i = 0; i < kMotorCount; ++i) rp[i] *= rp_scale;
        rp_lo *= rp_scale;
        rp_hi *= rp_scale;
        out.roll_pitch_limited = true;
      }
      // Priority 2: shift the collective share as little as possible so that roll/pitch fit (without
      // yaw); priority 3: then whatever yaw fits in the room left.
      collective = clampf(wanted, -rp_lo, f_max_ - rp_hi);
      out.thrust_limited = collective != wanted;
      for (int i = 0; i < kMotorCount; ++i) base[i] = collective + rp[i];
      if (!max_yaw_scale(base, yaw_share, yaw_scale, f)) {
        // Only round-off can get here (roll/pitch were made to fit around the collective): no yaw.
        yaw_scale = 0.0f;
        for (int i = 0; i < kMotorCount; ++i) f[i] = clampf(base[i], 0.0f, f_max_);
      }
    }
    out.yaw_limited = yaw_scale < 1.0f;
    // By the orthogonality of the columns, what the motors now produce (eq. 5.5) is the demand with the
    // collective shifted and the torque axes scaled (tested against the forward model).
    thrust = 4.0f * collective;
    out.achieved.torque = Vec3{torque.x * rp_scale, torque.y * rp_scale, torque.z * yaw_scale};
  } else {
    out.achieved.torque = torque;
  }
  out.achieved.thrust = thrust;

  for (int i = 0; i < kMotorCount; ++i) {
    out.rotor_speed_sq[i] = f[i] * inv_b_;         // w_bar_i of eq. 5.7
    out.command[i] = sqrtf(f[i] * inv_f_max_);     // u_i = w_i / w_max (vehicle.h motor model)
  }
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
