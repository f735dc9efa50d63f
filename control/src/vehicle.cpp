#include "quad/control/vehicle.h"

#include "quad/control/approx.h"

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
  if (!positive_finite(v.mass)) return "mass";
  if (!positive_finite(v.inertia)) return "inertia";
  if (!positive_finite(v.arm_length)) return "arm_length";
  if (!positive_finite(v.max_motor_thrust)) return "max_motor_thrust";
  if (!positive_finite(v.thrust_coeff)) return "thrust_coeff";
  if (!positive_finite(v.yaw_coeff)) return "yaw_coeff";
  if (v.frame != Frame::kPlus && v.frame != Frame::kX) return "frame";
  return nullptr;
}

}  // namespace ctrl
}  // namespace quad
