#include "quad/control/position_controller.h"

#include "quad/control/approx.h"

namespace quad {
namespace ctrl {

namespace {

// thesis eq. 8.20 on one axis (diagonal gains, eq. 8.21), with the errors of eq. 8.14.
float axis_command(float a_d, float kp, float kv, float p_err, float v_err) {
  return a_d - kp * tanh_approx(p_err) - kv * tanh_approx(v_err);
}

}  // namespace

Vec3 PositionController::update(const PositionSetpoint& sp, const Vec3& p, const Vec3& v) const {
  // Written out per axis rather than as a loop over Vec3::operator[] (cheaper on the AVR).
  return {axis_command(sp.a_d.x, gains_.kp.x, gains_.kv.x, p.x - sp.p_d.x, v.x - sp.v_d.x),
          axis_command(sp.a_d.y, gains_.kp.y, gains_.kv.y, p.y - sp.p_d.y, v.y - sp.v_d.y),
          axis_command(sp.a_d.z, gains_.kp.z, gains_.kv.z, p.z - sp.p_d.z, v.z - sp.v_d.z)};
}

const char* validate(const PositionGains& g) {
  if (!positive_finite(g.kp)) return "kp";
  if (!positive_finite(g.kv)) return "kv";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
