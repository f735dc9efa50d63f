#include "quad/control/thrust_attitude.h"

#include "angle.h"
#include "quad/control/approx.h"
#include "quad/math/float_bits.h"

namespace quad {
namespace ctrl {

namespace {
// The least a_z of the limit shortcut (header): half of g. Any value is correct (the tilt cap grows
// with a_z); this one covers hover and moderate descent. Above max_accel the shortcut is never taken.
constexpr float kFreeAz = 0.5f * kGravity;

}  // namespace

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
  const float tilt_cap_free = tan_max_tilt_ * kFreeAz;
  free_h_sq_ = tilt_cap_free * tilt_cap_free;
  // An a_z^2 bound with max_accel^2 - a_z^2 >= free_h_sq_ in float: 1e-4 of (max_accel^2 - free_h_sq_)
  // below the exact limit is far more than the round-off (a few 1e-8 of max_accel^2) whenever
  // free_h_sq_ < 0.98 max_accel^2; otherwise the shortcut is simply not used.
  free_az_sq_ = free_h_sq_ < 0.98f * max_accel_sq_ ? 0.9999f * (max_accel_sq_ - free_h_sq_) : 0.0f;
  tilt_cos_half_ = cosf(0.5f * p.max_tilt);
  tilt_sin_half_ = sinf(0.5f * p.max_tilt);
  inv_cos_tilt_ = 1.0f / cosf(p.max_tilt);
  cached_yaw_ = 0.0f;
  cached_yaw_quat_ = Quat::identity();
}

Quat ThrustAttitude::yaw_quat(float yaw_d) {
  // (Compared bit for bit, not as floats: a heading of -0 gives -0 in the quaternion's z, so the cache
  // must not hand the +0 heading's quaternion to it.)
  if (memcmp(&yaw_d, &cached_yaw_, sizeof yaw_d) != 0) {
    const float half = 0.5f * wrap_heading(yaw_d);
    cached_yaw_quat_ = Quat{cosf(half), 0.0f, 0.0f, sinf(half)};
    cached_yaw_ = yaw_d;
  }
  return cached_yaw_quat_;
}

AttitudeCommand ThrustAttitude::update(const Vec3& mu_d, float yaw_d) {
  AttitudeCommand cmd;  // (returned in place: no copy, and no temporary in the caller's frame)
  update(mu_d, yaw_d, cmd);
  return cmd;
}

void ThrustAttitude::update(const Vec3& mu_d, float yaw_d, AttitudeCommand& cmd) {
  if (!is_finite(mu_d) || !is_finite(yaw_d)) {
    cmd = AttitudeCommand{};
    cmd.thrust = params_.mass * kGravity;
    cmd.limited = true;
    return;
  }

  // thesis eq. 8.28: (T/m) R_d e_3 = g e_z - mu_d =: (h_x, h_y, a_z), the specific force the rotors must
  // produce, negated (thrust acts along body -e_3).
  float a_z = kGravity - mu_d.z;
  float h_x = -mu_d.x;
  float h_y = -mu_d.y;
  bool limited = false;

  // Limit 1: the thrust must point up (a_z > 0, away from the singularity of eq. 8.37) and be reachable.
  // (Compared on the bit patterns with the shortcut's tests below, float_bits.h: 290 cycles off the median
  // 200 Hz PIL iteration; a_z is finite, and validate() makes 0 < min_accel_ < max_accel_.)
  if (below_positive(a_z, min_accel_)) {
    a_z = min_accel_;
    limited = true;
  } else if (above_nonnegative(a_z, max_accel_)) {
    a_z = max_accel_;
    limited = true;
  }

  // Limits 2 and 3: tilt = atan(|h| / a_z) <= max_tilt, and |(h, a_z)| <= max thrust / m with the
  // vertical part kept.
  // The shortcut first (see the header: a_z >= kFreeAz makes the tilt cap at least free_h_sq_, and
  // a_z^2 <= free_az_sq_ the thrust cap, so h_sq <= h_max_sq below and the full test would not act).
  float h_sq = h_x * h_x + h_y * h_y;
  const float a_z_sq = a_z * a_z;
  const Quat yaw = yaw_quat(yaw_d);
  // (Squares and their caps are >= +0: on the bit patterns too.)
  if (!(at_least_positive(a_z, kFreeAz) && abs_at_most(a_z_sq, free_az_sq_) && abs_at_most(h_sq, free_h_sq_))) {
    const float tilt_cap = tan_max_tilt_ * a_z;
    const float thrust_cap = max_accel_sq_ - a_z_sq;
    const float tilt_cap_sq = tilt_cap * tilt_cap;
    const bool thrust_capped = thrust_cap < tilt_cap_sq;
    const float h_max_sq = thrust_capped ? maxf(thrust_cap, 0.0f) : tilt_cap_sq;
    if (h_sq > h_max_sq) {
      if (!thrust_capped) {
        command_at_tilt_limit(h_x, h_y, h_sq, a_z, tilt_cap, yaw, cmd);
        cmd.limited = true;
        return;
      }
      const float s = sqrtf(h_max_sq / h_sq);
      h_x *= s;
      h_y *= s;
      h_sq = h_max_sq;  // |s h|^2, up to rounding
      limited = true;
    }
  }
  command_within_limits(h_x, h_y, h_sq, a_z, a_z_sq, yaw, cmd);
  cmd.limited = limited;
}

// Q_tilt = (q0, -p_y K, p_x K, 0) with p = h and K = k (general form) or p = h / |h| and
// K = sin(max_tilt / 2) (at the tilt limit). errata "8.37 yaw": Q_d = Q_tilt (x) Q_yaw, the heading a
// rotation about the desired body z axis; with Q_yaw = (c, 0, 0, s) the Hamilton product (eq. 3.11) is
//   Q_d = (q0 c, p_x K s - p_y K c, p_x K c + p_y K s, q0 s),
// evaluated with K c and K s formed first (eight multiplications for tilt and heading together).
// w_c = q0 c, w_s = q0 s, k_c = K c, k_s = K s.
QUAD_STEP void ThrustAttitude::compose(float p_x, float p_y, float w_c, float w_s, float k_c, float k_s, float h_x,
                                       float h_y, float a_z, AttitudeCommand& cmd) {
  cmd.q_d = Quat{w_c, p_x * k_s - p_y * k_c, p_x * k_c + p_y * k_s, w_s};
  cmd.mu_applied = Vec3{-h_x, -h_y, kGravity - a_z};
}

// The general form: thrust and attitude of the (limited) demand (h, a_z).
QUAD_STEP void ThrustAttitude::command_within_limits(float h_x, float h_y, float h_sq, float a_z, float a_z_sq,
                                                     const Quat& yaw, AttitudeCommand& cmd) const {
  const float n = sqrtf(h_sq + a_z_sq);  // N = ||g e_z - mu_d|| >= min_accel > 0
  cmd.thrust = params_.mass * n;         // thesis eq. 8.30

  // thesis eq. 8.37a/b as corrected in the errata (u = (g e_z - mu_d)/N, v = e_z in eq. 8.35):
  //   q0 = sqrt((1 + a_z/N)/2),  q = (mu_d2, -mu_d1, 0) / (2 N q0) = (-h_y, h_x, 0) / (2 N q0).
  // With k = 1/sqrt(2 N (N + a_z)) these are q0 = (N + a_z) k and q = (-h_y, h_x, 0) k: one square
  // root and one division, and a unit quaternion by construction. a_z > 0 keeps N + a_z > N > 0.
  const float n_a = n + a_z;
  const float k = 1.0f / sqrtf((n + n) * n_a);  // (2 N = N + N exactly)
  const float k_c = k * yaw.w;
  const float k_s = k * yaw.z;
  compose(h_x, h_y, n_a * k_c, n_a * k_s, k_c, k_s, h_x, h_y, a_z, cmd);
}

// At the tilt limit the tilt is max_tilt itself, so N = a_z / cos(max_tilt) (eq. 8.30) and Q_tilt is the
// rotation by max_tilt about e_z x u_h, u_h = h / |h| (eq. 8.37a/b with u = (sin(max_tilt) u_h,
// cos(max_tilt))): one square root and one division instead of three and two. Not bit-identical to the
// general form: within 2.4e-7 (tested). h is scaled to the tilt cap tan(max_tilt) a_z.
QUAD_STEP void ThrustAttitude::command_at_tilt_limit(float h_x, float h_y, float h_sq, float a_z, float tilt_cap,
                                                     const Quat& yaw, AttitudeCommand& cmd) const {
  const float inv_h = 1.0f / sqrtf(h_sq);
  const float p_x = h_x * inv_h;
  const float p_y = h_y * inv_h;
  cmd.thrust = params_.mass * (a_z * inv_cos_tilt_);  // thesis eq. 8.30
  compose(p_x, p_y, tilt_cos_half_ * yaw.w, tilt_cos_half_ * yaw.z, tilt_sin_half_ * yaw.w, tilt_sin_half_ * yaw.z,
          p_x * tilt_cap, p_y * tilt_cap, a_z, cmd);
}

const char* validate(const ThrustAttitudeParams& p) {
  if (!positive_finite(p.mass)) return "mass";
  if (!(positive_finite(p.max_tilt) && p.max_tilt <= 80.0f * kDegToRad)) return "max_tilt";
  if (!positive_finite(p.min_thrust)) return "min_thrust";
  if (!(is_finite(p.max_thrust) && p.max_thrust > p.min_thrust)) return "max_thrust";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
