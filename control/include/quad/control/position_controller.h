// Bounded position controller, thesis eq. 8.20:
//   mu_d = a_d - K_p tanh(p - p_d) - K_v tanh(v - v_d)        (tanh element-wise, K_p, K_v diagonal)
// mu_d is the desired "virtual acceleration" of eq. 8.13 (NED, m/s^2, gravity not included: hover is
// mu_d = 0). Each axis contributes at most k_p + k_v, so mu_d is bounded a priori. tanh is
// tanh_approx() of approx.h (|error| < 1.4e-3, < 1e-6 for |x| <= 1.2), cheap enough for the AVR.
//
// Usage:
//   quad::ctrl::PositionController pc;                  // table 8.1 gains
//   quad::ctrl::PositionSetpoint sp;
//   sp.p_d = {0.0f, 0.0f, -1.5f};                        // 1.5 m above the origin (NED: z down)
//   quad::Vec3 mu_d = pc.update(sp, p_est, v_est);       // then ThrustAttitude::update(mu_d, sp.yaw_d)
#pragma once

#include "quad/math/math.h"

namespace quad {
namespace ctrl {

// Diagonals of K_p and K_v (eq. 8.21). Defaults: thesis table 8.1.
struct PositionGains {
  Vec3 kp{3.625f, 3.625f, 3.625f};   // m/s^2 per unit tanh(position error)
  Vec3 kv{11.875f, 11.875f, 3.5f};   // m/s^2 per unit tanh(velocity error)
};

// What the vehicle should do now (all NED): position, velocity and acceleration feed-forward, heading.
struct PositionSetpoint {
  Vec3 p_d;          // m
  Vec3 v_d;          // m/s
  Vec3 a_d;          // m/s^2
  float yaw_d = 0.0f; // rad, heading of the body x axis (0 = north, +pi/2 = east)
};

class PositionController {
 public:
  PositionController() = default;
  explicit PositionController(const PositionGains& gains) : gains_(gains) {}

  void set_gains(const PositionGains& gains) { gains_ = gains; }
  const PositionGains& gains() const { return gains_; }

  // mu_d of eq. 8.20 from the estimated position p and velocity v (NED).
  Vec3 update(const PositionSetpoint& sp, const Vec3& p, const Vec3& v) const;

 private:
  PositionGains gains_;
};

// Returns nullptr when the gains are usable (finite, positive), else the name of the first bad field.
const char* validate(const PositionGains& g);

}  // namespace ctrl
}  // namespace quad
