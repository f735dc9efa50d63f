#include "quad/control/position_controller.h"

#include "quad/control/approx.h"

namespace quad {
namespace ctrl {

Vec3 PositionController::update(const PositionSetpoint& sp, const Vec3& p, const Vec3& v) const {
  const Vec3 p_err = p - sp.p_d;  // thesis eq. 8.14
  const Vec3 v_err = v - sp.v_d;
  Vec3 mu;
  for (int i = 0; i < 3; ++i) {
    // thesis eq. 8.20, per axis (diagonal gains, eq. 8.21)
    mu[i] = sp.a_d[i] - gains_.kp[i] * tanh_approx(p_err[i]) - gains_.kv[i] * tanh_approx(v_err[i]);
  }
  return mu;
}

const char* validate(const PositionGains& g) {
  if (!(is_finite(g.kp) && g.kp.x > 0.0f && g.kp.y > 0.0f && g.kp.z > 0.0f)) return "kp";
  if (!(is_finite(g.kv) && g.kv.x > 0.0f && g.kv.y > 0.0f && g.kv.z > 0.0f)) return "kv";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
