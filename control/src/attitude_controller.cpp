#include "quad/control/attitude_controller.h"

namespace quad {
namespace ctrl {

Quat attitude_error(const Quat& q, const Quat& q_d) {
  // thesis eq. 8.38, Q~ = Q_d^-1 (x) Q; errata 8.39: the representative with q~0 >= 0.
  return canonical(conjugate(q_d) * q);
}

Vec3 AttitudeController::update(const Quat& q, const Vec3& omega, const Quat& q_d, const Vec3& omega_d) const {
  const Vec3 q_err = attitude_error(q, q_d).vec();
  // thesis eq. 8.39: tau = -alpha sign(q~0) q~ - Gamma Omega (plus the optional rate feed-forward).
  return q_err * (-gains_.alpha) - hadamard(gains_.gamma, omega - omega_d);
}

const char* validate(const AttitudeGains& g) {
  if (!(is_finite(g.alpha) && g.alpha > 0.0f)) return "alpha";
  if (!(is_finite(g.gamma) && g.gamma.x > 0.0f && g.gamma.y > 0.0f && g.gamma.z > 0.0f)) return "gamma";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
