// Baseline: Mahony's nonlinear complementary filter on SO(3) (seed 001, "Nonlinear complementary
// filter", with the errata's skew operator), in quaternion form.
//
// Usage:
//   quad::est::MahonyFilter f;                   // kp, ki, reference field: MahonyParams
//   f.initialize(accel_frd, mag_frd);
//   f.update(gyro_frd, accel_frd, mag_frd, mag_valid, dt);   f.attitude() is q_IB
//
// Seed 001: R_tilde = R_hat^T R_m, xi = vex(Pa(R_tilde)), with R_m the attitude measured from the
// accelerometer and magnetometer (TRIAD). The seed writes the direct form, which rotates the gyro by the
// noisy R_m; this uses Mahony et al.'s passive form R_hat' = R_hat sk(Omega_m - b + kp xi) with the
// integral b' = -ki xi, which has the same error dynamics and keeps measurement noise out of the gyro.
#pragma once

#include <stdint.h>

#include "quad/math/math.h"

namespace quad {
namespace est {

struct MahonyParams {
  float kp = 1.0f;    // 1/s
  float ki = 0.03f;   // 1/s^2
  Vec3 mag_ref_ned{0.42f, 0.0f, 0.91f};
  bool mag_ref_from_init = true;
  float accel_norm_tolerance = 0.2f;  // the correction is skipped outside | |a|/g - 1 | < tolerance
};

class MahonyFilter {
 public:
  MahonyFilter() : MahonyFilter(MahonyParams{}) {}
  explicit MahonyFilter(const MahonyParams& params) : params_(params) {}

  bool initialize(const Vec3& accel_frd, const Vec3& mag_frd);
  void reset(const Quat& q_ib, const Vec3& gyro_bias) {
    q_ = normalized(q_ib);
    bias_ = gyro_bias;
  }
  void update(const Vec3& gyro_frd, const Vec3& accel_frd, const Vec3& mag_frd, bool mag_valid, float dt);

  const Quat& attitude() const { return q_; }
  const Vec3& gyro_bias() const { return bias_; }
  uint32_t rejected() const { return rejected_; }

 private:
  MahonyParams params_;
  Quat q_;
  Vec3 bias_;
  Vec3 last_mag_;  // the magnetometer runs slower than the IMU: the latest valid sample is reused
  bool have_mag_ = false;
  uint32_t rejected_ = 0;
};

}  // namespace est
}  // namespace quad
