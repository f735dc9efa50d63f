// Vehicle description shared by the controller, the firmware and the simulator: mass, inertia and the
// rotor layout with its motor model (thesis sec. 5.1).
//
// Usage:
//   quad::ctrl::VehicleParams v;            // the thesis' 3DR Quad-C in plus configuration (defaults below)
//   v.frame = quad::ctrl::Frame::kX;        // or the X layout
//   quad::ctrl::MotorLayout m = quad::ctrl::motor_layout(v.frame, v.arm_length, 2);  // where motor 2 sits
//
// MOTOR ORDER (the order of HIL_ACTUATOR_CONTROLS controls[0..3], of every motor array in the code base,
// and of the simulator's rotors). Viewed from above, the order runs counter-clockwise; "CCW" / "CW" is the
// propeller's spin viewed from above.
//
//   index | Frame::kPlus (thesis eq. 5.7)  | Frame::kX (the plus layout turned 45 deg counter-clockwise)
//   ------+--------------------------------+-------------------------------------------------------------
//     0   | front  (+d, 0)        CCW      | front-left  (+d/sqrt2, -d/sqrt2)  CCW
//     1   | left   (0, -d)        CW       | back-left   (-d/sqrt2, -d/sqrt2)  CW
//     2   | back   (-d, 0)        CCW      | back-right  (-d/sqrt2, +d/sqrt2)  CCW
//     3   | right  (0, +d)        CW       | front-right (+d/sqrt2, +d/sqrt2)  CW
//
// (x, y) are the rotor axis positions in the body frame FRD (x forward, y right), metres from the centre
// of mass. A CCW propeller's drag torque on the airframe points along body +z (down): it yaws the nose
// right, which is positive yaw in FRD. This reproduces the signs of thesis eq. 5.4/5.6: tau_3 =
// kappa (w_f^2 + w_b^2 - w_l^2 - w_r^2).
//
// MOTOR MODEL. Rotor i gives thrust f_i = b w_i^2 along body -z and yaw torque s_i kappa w_i^2 (s_i = +1
// for CCW, -1 for CW), thesis eq. 5.3/5.4. Its normalised command is u_i = w_i / w_max in [0, 1], so
// f_i = f_max u_i^2 with f_max = b w_max^2 the maximum thrust of one motor (the PX4/Gazebo convention:
// the command is proportional to rotor speed).
#pragma once

#include <stdint.h>

#include "quad/math/math.h"

namespace quad {
namespace ctrl {

constexpr int kMotorCount = 4;

enum class Frame : uint8_t { kPlus = 0, kX = 1 };

// Defaults: the thesis' Quad-C (reference facts: 880 g maximum thrust per motor, 10 x 4.7 in props at
// up to 6500 RPM). The thesis gives no mass, inertia or arm length; the values below are a plausible
// Quad-C, derived in docs/control.md (1.4 kg all-up; four 80 g motor+ESC+prop masses at 0.26 m plus a
// compact centre body give I_xx = I_yy ~ 0.015 kg m^2, I_zz ~ 0.027 kg m^2).
struct VehicleParams {
  float mass = 1.4f;                                    // kg
  Vec3 inertia{0.015f, 0.015f, 0.027f};                 // principal moments about FRD axes, kg m^2
  float arm_length = 0.26f;                             // d: centre of mass to rotor axis, m
  float max_motor_thrust = 0.880f * kGravity;           // f_max of one motor, N (880 g)
  float thrust_coeff = 1.863e-5f;                       // b, N / (rad/s)^2: f_max at 6500 RPM (680.7 rad/s)
  float yaw_coeff = 0.016f * 1.863e-5f;                 // kappa, N m / (rad/s)^2: 0.016 m times b (RotorS)
  Frame frame = Frame::kPlus;

  float max_rotor_speed() const { return sqrtf(max_motor_thrust / thrust_coeff); }  // w_max, rad/s
  float max_total_thrust() const { return static_cast<float>(kMotorCount) * max_motor_thrust; }
  float hover_thrust() const { return mass * kGravity; }
};

// Where one rotor sits and which way it turns (see the table above).
struct MotorLayout {
  float x = 0.0f;    // body x (forward) of the rotor axis, m
  float y = 0.0f;    // body y (right), m
  float spin = 1.0f; // +1: CCW viewed from above (yaw torque along +z); -1: CW
};

// Rotor `index` (0..3) of `frame` with arm length `arm`. Indexes outside 0..3 are clamped into range.
MotorLayout motor_layout(Frame frame, float arm, int index);

// Checks a parameter set; returns nullptr when it is usable, else the name of the first bad field
// ("mass", "inertia", "arm_length", "max_motor_thrust", "thrust_coeff", "yaw_coeff", "frame").
const char* validate(const VehicleParams& v);

}  // namespace ctrl
}  // namespace quad
