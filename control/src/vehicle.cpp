#include "quad/control/vehicle.h"

namespace quad {
namespace ctrl {

namespace {
constexpr float kInvSqrt2 = 0.70710678118654752f;
}  // namespace

MotorLayout motor_layout(Frame frame, float arm, int index) {
  const int i = index < 0 ? 0 : (index > 3 ? 3 : index);
  // Counter-clockwise seen from above, starting at the front (plus) or front-left (X) arm; the spin
  // alternates CCW, CW, CCW, CW so opposite rotors turn the same way (thesis eq. 5.4c). Computed rather
  // than read from tables: on the AVR constant tables would sit in SRAM.
  MotorLayout m;
  if (frame == Frame::kX) {
    const float s = arm * kInvSqrt2;
    m.x = (i == 0 || i == 3) ? s : -s;  // front-left, front-right
    m.y = (i >= 2) ? s : -s;            // back-right, front-right
  } else {
    m.x = i == 0 ? arm : (i == 2 ? -arm : 0.0f);
    m.y = i == 3 ? arm : (i == 1 ? -arm : 0.0f);
  }
  m.spin = (i % 2 == 0) ? 1.0f : -1.0f;
  return m;
}

const char* validate(const VehicleParams& v) {
  if (!(is_finite(v.mass) && v.mass > 0.0f)) return "mass";
  if (!(is_finite(v.inertia) && v.inertia.x > 0.0f && v.inertia.y > 0.0f && v.inertia.z > 0.0f)) return "inertia";
  if (!(is_finite(v.arm_length) && v.arm_length > 0.0f)) return "arm_length";
  if (!(is_finite(v.max_motor_thrust) && v.max_motor_thrust > 0.0f)) return "max_motor_thrust";
  if (!(is_finite(v.thrust_coeff) && v.thrust_coeff > 0.0f)) return "thrust_coeff";
  if (!(is_finite(v.yaw_coeff) && v.yaw_coeff > 0.0f)) return "yaw_coeff";
  if (v.frame != Frame::kPlus && v.frame != Frame::kX) return "frame";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
