#include "quad/estimation/mahony_filter.h"

#include "gravity_gate.h"
#include "quad/estimation/vector_attitude.h"

namespace quad {
namespace est {

bool MahonyFilter::initialize(const Vec3& accel_frd, const Vec3& mag_frd) {
  if (params_.mag_ref_from_init && !magnetic_reference_from_sample(accel_frd, mag_frd, params_.mag_ref_ned)) {
    return false;
  }
  Quat q;
  if (!attitude_from_vectors(accel_frd, mag_frd, params_.mag_ref_ned, q)) return false;
  q_ = q;
  bias_ = Vec3{};
  last_mag_ = mag_frd;
  have_mag_ = true;
  return true;
}

void MahonyFilter::update(const Vec3& gyro, const Vec3& accel, const Vec3& mag, bool mag_valid, float dt) {
  if (!is_finite(gyro) || !(dt > 0.0f) || !(dt <= 0.5f)) {
    ++rejected_;
    return;
  }
  if (mag_valid && is_finite(mag)) {
    last_mag_ = mag;
    have_mag_ = true;
  }
  Vec3 xi;
  Quat q_m;
  if (have_mag_ && near_gravity(norm_sq(accel), params_.accel_norm_tolerance) &&
      attitude_from_vectors(accel, last_mag_, params_.mag_ref_ned, q_m)) {
    // seed 001: R_tilde = R_hat^T R_m, xi = vex(Pa(R_tilde)). With R_tilde = R(q_tilde),
    // Pa(R) = (R - R^T)/2 = 2 w sk(v), so xi = 2 w v (invariant under q_tilde -> -q_tilde).
    const Quat qt = conjugate(q_) * q_m;
    xi = qt.vec() * (2.0f * qt.w);
  } else {
    ++rejected_;
  }
  // Passive form: R_hat' = R_hat sk(Omega_m - b + kp xi), b' = -ki xi.
  const Vec3 omega = gyro - bias_ + xi * params_.kp;
  const Quat q_next = integrate_second_order(q_, omega, dt);
  const Vec3 b_next = bias_ - xi * (params_.ki * dt);
  if (is_finite(q_next) && is_finite(b_next)) {
    q_ = q_next;
    bias_ = b_next;
  }
}

}  // namespace est
}  // namespace quad
