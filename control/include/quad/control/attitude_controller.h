// Quaternion PD attitude controller, thesis eq. 8.38/8.39 with the errata's shortest-rotation fix:
//   Q~  = Q_d^-1 (x) Q                      (eq. 8.38; with q = q_IB this is the rotation from the desired
//                                            body frame to the actual one, expressed in body axes)
//   tau = -alpha sign(q~0) q~ - Gamma (Omega - Omega_d)     (eq. 8.39, body frame FRD, N m)
// sign(q~0) picks the representative with q~0 >= 0: the vehicle always turns the short way round and
// never unwinds a full turn (errata 8.39). Omega_d is an optional body-rate feed-forward (zero in the
// thesis). For a small error q~ ~ (1, theta/2) with theta the error rotation vector, so alpha/2 is the
// torque per radian.
//
// Usage:
//   quad::ctrl::AttitudeController ac;                 // table 8.1: alpha 3.0, Gamma diag(0.625, 0.625, 0.5)
//   quad::Vec3 tau = ac.update(q_est, omega_gyro, cmd.q_d);
#pragma once

#include "quad/math/math.h"

namespace quad {
namespace ctrl {

// Defaults: thesis table 8.1.
struct AttitudeGains {
  float alpha = 3.0f;                // N m per unit of the error quaternion's vector part
  Vec3 gamma{0.625f, 0.625f, 0.5f};  // diagonal of Gamma, N m per rad/s
};

class AttitudeController {
 public:
  AttitudeController() = default;
  explicit AttitudeController(const AttitudeGains& gains) : gains_(gains) {}

  void set_gains(const AttitudeGains& gains) { gains_ = gains; }
  const AttitudeGains& gains() const { return gains_; }

  // Control torque (body FRD, N m) from the attitude estimate q (q_IB), the body rate omega (rad/s),
  // the desired attitude q_d and optionally a desired body rate omega_d.
  Vec3 update(const Quat& q, const Vec3& omega, const Quat& q_d, const Vec3& omega_d) const {
    return update(q, omega - omega_d, q_d);
  }
  // The thesis' law: Omega_d = 0.
  Vec3 update(const Quat& q, const Vec3& omega, const Quat& q_d) const;

 private:
  AttitudeGains gains_;
};

// The error quaternion of eq. 8.38, returned with a non-negative scalar part (the short way round).
Quat attitude_error(const Quat& q, const Quat& q_d);

// Returns nullptr when usable (finite, positive), else the name of the first bad field.
const char* validate(const AttitudeGains& g);

}  // namespace ctrl
}  // namespace quad
