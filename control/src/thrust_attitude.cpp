#include "quad/control/thrust_attitude.h"

#include "angle.h"

namespace quad {
namespace ctrl {

ThrustAttitudeParams ThrustAttitudeParams::for_vehicle(const VehicleParams& v) {
  ThrustAttitudeParams p;
  p.mass = v.mass;
  p.min_thrust = 0.1f * v.hover_thrust();
  p.max_thrust = v.max_total_thrust();
  return p;
}

ThrustAttitude::ThrustAttitude() { set_params(ThrustAttitudeParams{}); }

ThrustAttitude::ThrustAttitude(const ThrustAttitudeParams& p) { set_params(p); }

void ThrustAttitude::set_params(const ThrustAttitudeParams& p) {
  params_ = p;
  tan_max_tilt_ = tanf(p.max_tilt);
  min_accel_ = p.min_thrust / p.mass;
  max_accel_ = p.max_thrust / p.mass;
  max_accel_sq_ = max_accel_ * max_accel_;
  cached_yaw_ = 0.0f;
  cached_yaw_quat_ = Quat::identity();
}

Quat ThrustAttitude::yaw_quat(float yaw_d) {
  if (yaw_d != cached_yaw_) {
    const float half = 0.5f * wrap_heading(yaw_d);
    cached_yaw_quat_ = Quat{cosf(half), 0.0f, 0.0f, sinf(half)};
    cached_yaw_ = yaw_d;
  }
  return cached_yaw_quat_;
}

AttitudeCommand ThrustAttitude::update(const Vec3& mu_d, float yaw_d) {
  AttitudeCommand cmd;
  if (!is_finite(mu_d) || !is_finite(yaw_d)) {
    cmd.thrust = params_.mass * kGravity;
    cmd.limited = true;
    return cmd;
  }

  // thesis eq. 8.28: (T/m) R_d e_3 = g e_z - mu_d =: (h_x, h_y, a_z), the specific force the rotors must
  // produce, negated (thrust acts along body -e_3).
  float a_z = kGravity - mu_d.z;
  float h_x = -mu_d.x;
  float h_y = -mu_d.y;
  bool limited = false;

  // Limit 1: the thrust must point up (a_z > 0, away from the singularity of eq. 8.37) and be reachable.
  if (a_z < min_accel_) {
    a_z = min_accel_;
    limited = true;
  } else if (a_z > max_accel_) {
    a_z = max_accel_;
    limited = true;
  }

  // Limits 2 and 3: tilt = atan(|h| / a_z) <= max_tilt, and |(h, a_z)| <= max thrust / m with the
  // vertical part kept.
  float h_sq = h_x * h_x + h_y * h_y;
  const float a_z_sq = a_z * a_z;
  const float tilt_cap = tan_max_tilt_ * a_z;
  const float h_max_sq = minf(tilt_cap * tilt_cap, maxf(max_accel_sq_ - a_z_sq, 0.0f));
  if (h_sq > h_max_sq) {
    const float s = sqrtf(h_max_sq / h_sq);
    h_x *= s;
    h_y *= s;
    h_sq = h_max_sq;  // |s h|^2, up to rounding
    limited = true;
  }

  const float n = sqrtf(h_sq + a_z_sq);  // N = ||g e_z - mu_d|| >= min_accel > 0
  cmd.thrust = params_.mass * n;                              // thesis eq. 8.30

  // thesis eq. 8.37a/b as corrected in the errata (u = (g e_z - mu_d)/N, v = e_z in eq. 8.35):
  //   q0 = sqrt((1 + a_z/N)/2),  q = (mu_d2, -mu_d1, 0) / (2 N q0) = (-h_y, h_x, 0) / (2 N q0).
  // With k = 1/sqrt(2 N (N + a_z)) these are q0 = (N + a_z) k and q = (-h_y, h_x, 0) k: one square root
  // and one division, and a unit quaternion by construction. a_z > 0 keeps N + a_z > N > 0.
  const float k = 1.0f / sqrtf(2.0f * n * (n + a_z));
  const float tw = (n + a_z) * k, tx = -h_y * k, ty = h_x * k;  // Q_tilt = (tw, tx, ty, 0)

  // errata "8.37 yaw": Q_d = Q_tilt (x) Q_yaw, the heading a rotation about the desired body z axis.
  // With Q_yaw = (c, 0, 0, s) the Hamilton product (eq. 3.11) reduces to eight multiplications.
  const Quat yaw = yaw_quat(yaw_d);
  cmd.q_d = Quat{tw * yaw.w, tx * yaw.w + ty * yaw.z, ty * yaw.w - tx * yaw.z, tw * yaw.z};
  cmd.mu_applied = Vec3{-h_x, -h_y, kGravity - a_z};
  cmd.limited = limited;
  return cmd;
}

const char* validate(const ThrustAttitudeParams& p) {
  if (!(is_finite(p.mass) && p.mass > 0.0f)) return "mass";
  if (!(is_finite(p.max_tilt) && p.max_tilt > 0.0f && p.max_tilt <= 80.0f * kDegToRad)) return "max_tilt";
  if (!(is_finite(p.min_thrust) && p.min_thrust > 0.0f)) return "min_thrust";
  if (!(is_finite(p.max_thrust) && p.max_thrust > p.min_thrust)) return "max_thrust";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
