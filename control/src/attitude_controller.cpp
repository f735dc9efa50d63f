#include "quad/control/attitude_controller.h"

namespace quad {
namespace ctrl {

Quat attitude_error(const Quat& q, const Quat& q_d) {
  // thesis eq. 8.38, Q~ = Q_d^-1 (x) Q; errata 8.39: the representative with q~0 >= 0.
  return canonical(conjugate(q_d) * q);
}

Vec3 AttitudeController::update(const Quat& q, const Vec3& omega, const Quat& q_d) const {
  // thesis eq. 8.38: Q~ = Q_d^-1 (x) Q, and eq. 8.39: tau = -alpha sign(q~0) q~ - Gamma Omega. The sign
  // goes into the gain rather than onto the quaternion (errata 8.39: the short way round).
  const Quat e = conjugate(q_d) * q;
  const float gain = e.w < 0.0f ? gains_.alpha : -gains_.alpha;
  return e.vec() * gain - hadamard(gains_.gamma, omega);
}

const char* validate(const AttitudeGains& g) {
  if (!(is_finite(g.alpha) && g.alpha > 0.0f)) return "alpha";
  if (!(is_finite(g.gamma) && g.gamma.x > 0.0f && g.gamma.y > 0.0f && g.gamma.z > 0.0f)) return "gamma";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
