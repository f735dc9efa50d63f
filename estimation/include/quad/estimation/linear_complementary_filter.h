// Baseline: the linear complementary filter of seed 001, on roll, pitch and yaw separately.
//
// Usage:
//   quad::est::LinearComplementaryFilter f;      // tau, reference field: LinearComplementaryParams
//   f.initialize(accel_frd, mag_frd);
//   f.update(gyro_frd, accel_frd, mag_frd, mag_valid, dt);   f.euler(), f.attitude()
//
// theta(k) = tau/(tau+T) (theta(k-1) + T theta_dot) + T/(tau+T) theta_m(k) per angle, with theta_m from
// the accelerometer (theta_m = asin(a_x/g), phi_m = -asin(a_y/(g cos theta_m)), here in the atan2 form
// that stays defined at any tilt) and psi_m from the tilt-compensated magnetometer (errata sign:
// psi = atan2(-m_ye, m_xe), plus the reference's declination). The Euler rates come from the gyro through
// the full kinematic matrix of the seed (its small-angle simplification is not used). The filter has
// no bias estimate: that is one of the things it is a baseline for.
#pragma once

#include <stdint.h>

#include "quad/math/math.h"

namespace quad {
namespace est {

struct LinearComplementaryParams {
  float tau = 1.0f;  // s; the seed's 0.95/0.05 split at T = 0.01 s is tau = 0.19 s
  Vec3 mag_ref_ned{0.42f, 0.0f, 0.91f};  // only its declination atan2(m_E, m_N) is used
  float accel_norm_tolerance = 0.2f;
};

class LinearComplementaryFilter {
 public:
  LinearComplementaryFilter() : LinearComplementaryFilter(LinearComplementaryParams{}) {}
  explicit LinearComplementaryFilter(const LinearComplementaryParams& params) : params_(params) {}

  bool initialize(const Vec3& accel_frd, const Vec3& mag_frd);
  void update(const Vec3& gyro_frd, const Vec3& accel_frd, const Vec3& mag_frd, bool mag_valid, float dt);

  const Euler& euler() const { return e_; }
  Quat attitude() const { return from_euler(e_); }

 private:
  LinearComplementaryParams params_;
  Euler e_;
};

}  // namespace est
}  // namespace quad
