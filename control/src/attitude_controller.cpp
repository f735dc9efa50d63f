#include "quad/control/attitude_controller.h"

#include "quad/control/approx.h"
#include "quad/math/float_bits.h"

namespace quad {
namespace ctrl {

Quat attitude_error(const Quat& q, const Quat& q_d) {
  // thesis eq. 8.38, Q~ = Q_d^-1 (x) Q; errata 8.39: the representative with q~0 >= 0.
  return canonical(conjugate(q_d) * q);
}

Vec3 AttitudeController::update(const Quat& q, const Vec3& omega, const Quat& q_d) const {
  // thesis eq. 8.38: Q~ = Q_d^-1 (x) Q, and eq. 8.39: tau = -alpha sign(q~0) q~ - Gamma Omega. The sign
  // goes into the gain rather than onto the quaternion (errata 8.39: the short way round).
  // The conjugate built in place and the torque written out in components: the same operations in the
  // same order as conjugate(q_d) * q, e.vec() * gain - hadamard(gamma, omega), so the torque is
  // bit-identical, with three fewer out-of-line helper calls and their copies on the AVR.
  // Q_d* (x) Q (eq. 3.12: the conjugate) in components: eq. 3.11 with p = (w, -x, -y, -z), where
  // a - (-b) c is a + b c exactly, so these are operator*'s roundings.
  const Quat e{q_d.w * q.w + q_d.x * q.x + q_d.y * q.y + q_d.z * q.z,
               q_d.w * q.x - q_d.x * q.w - q_d.y * q.z + q_d.z * q.y,
               q_d.w * q.y + q_d.x * q.z - q_d.y * q.w - q_d.z * q.x,
               q_d.w * q.z - q_d.x * q.y + q_d.y * q.x - q_d.z * q.w};
  // (At e.w = +-0 the error is 180 deg: both ways round are equally short, and -0 goes the + way. The
  // sign on the bit pattern, float_bits.h: 100 cycles off the median 200 Hz PIL iteration.)
  const float gain = negative(e.w) ? gains_.alpha : -gains_.alpha;
  return {e.x * gain - gains_.gamma.x * omega.x, e.y * gain - gains_.gamma.y * omega.y,
          e.z * gain - gains_.gamma.z * omega.z};
}

const char* validate(const AttitudeGains& g) {
  if (!positive_finite(g.alpha)) return "alpha";
  if (!positive_finite(g.gamma)) return "gamma";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
