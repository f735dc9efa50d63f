#include "quad/estimation/linear_complementary_filter.h"

#include "gravity_gate.h"

namespace quad {
namespace est {

namespace {

// Roll and pitch from the accelerometer: seed 001's theta_m = asin(a_x/g), phi_m = -asin(a_y/(g cos
// theta_m)), written with atan2 so that they hold for any accelerometer norm and any roll.
void tilt_from_accel(const Vec3& a, float& roll, float& pitch) {
  roll = atan2f(-a.y, -a.z);
  pitch = atan2f(a.x, sqrtf(a.y * a.y + a.z * a.z));
}

// Heading from the tilt-compensated magnetometer (seed 001; errata sign psi = atan2(-m_ye, m_xe)).
float heading_from_mag(const Vec3& m, float roll, float pitch, float declination) {
  const float cf = cosf(roll), sf = sinf(roll), ct = cosf(pitch), st = sinf(pitch);
  const float mx = m.x * ct + m.y * sf * st + m.z * cf * st;
  const float my = m.y * cf - m.z * sf;
  return wrap_pi(atan2f(-my, mx) + declination);
}

float declination_of(const Vec3& ref) { return atan2f(ref.y, ref.x); }

}  // namespace

bool LinearComplementaryFilter::initialize(const Vec3& accel, const Vec3& mag) {
  if (!is_finite(accel) || !is_finite(mag) || !(norm_sq(accel) > 0.0f)) return false;
  tilt_from_accel(accel, e_.roll, e_.pitch);
  e_.yaw = heading_from_mag(mag, e_.roll, e_.pitch, declination_of(params_.mag_ref_ned));
  return true;
}

void LinearComplementaryFilter::update(const Vec3& gyro, const Vec3& accel, const Vec3& mag, bool mag_valid,
                                       float dt) {
  if (!is_finite(gyro) || !(dt > 0.0f) || !(dt <= 0.5f)) return;
  // Euler rates from the body rates (seed 001, the full kinematic matrix).
  const float cf = cosf(e_.roll), sf = sinf(e_.roll), ct = cosf(e_.pitch), tt = tanf(e_.pitch);
  const float inv_ct = absf(ct) > 1e-3f ? 1.0f / ct : 1e3f * signf(ct);
  const float s = sf * gyro.y + cf * gyro.z;
  Euler pred;
  pred.roll = wrap_pi(e_.roll + dt * (gyro.x + tt * s));
  pred.pitch = e_.pitch + dt * (cf * gyro.y - sf * gyro.z);
  pred.yaw = wrap_pi(e_.yaw + dt * s * inv_ct);

  // theta(k) = tau/(tau+T) theta_pred + T/(tau+T) theta_m, written as a blend of the wrapped innovation.
  const float alpha = dt / (params_.tau + dt);
  if (near_gravity(norm_sq(accel), params_.accel_norm_tolerance)) {
    float roll_m, pitch_m;
    tilt_from_accel(accel, roll_m, pitch_m);
    pred.roll = wrap_pi(pred.roll + alpha * wrap_pi(roll_m - pred.roll));
    pred.pitch = clampf(pred.pitch + alpha * (pitch_m - pred.pitch), -kHalfPi, kHalfPi);
  }
  if (mag_valid && is_finite(mag) && norm_sq(mag) > 0.0f) {
    const float yaw_m = heading_from_mag(mag, pred.roll, pred.pitch, declination_of(params_.mag_ref_ned));
    pred.yaw = wrap_pi(pred.yaw + alpha * wrap_pi(yaw_m - pred.yaw));
  }
  e_ = pred;
}

}  // namespace est
}  // namespace quad
