// Setpoint shaping: moving to a new position target along a smooth path instead of a step. The shaper
// keeps a reference state (p, v) and moves it towards the target with |v| <= max_speed and
// |a| <= max_accel (Euclidean norms, NED), braking so it arrives without overshoot; its output feeds
// p_d, v_d, a_d of eq. 8.20. The target may change at any time, also mid-move: the reference stays
// continuous in position and velocity.
//
// Per step: the speed towards the target is the braking-limited square-root law of ArduPilot's
// sqrt_controller (linear, gain k, within a short distance of the target, so the end is a smooth
// exponential rather than bang-bang chatter), capped at max_speed; the acceleration that reaches that
// velocity in one step is capped at max_accel.
//
// Usage:
//   quad::ctrl::SetpointShaper shaper;            // defaults: 1 m/s, 1 m/s^2
//   shaper.reset(p_now);                          // start from where the vehicle is, at rest
//   shaper.set_target({2.0f, 0.0f, -1.5f});
//   each control step: shaper.update(dt, sp);     // fills sp.p_d, sp.v_d, sp.a_d (yaw_d untouched)
#pragma once

#include "quad/control/position_controller.h"
#include "quad/math/math.h"

namespace quad {
namespace ctrl {

struct ShaperParams {
  float max_speed = 1.0f;   // m/s
  float max_accel = 1.0f;   // m/s^2
  float final_gain = 4.0f;  // k, 1/s: the exponential time constant of the last few centimetres is 1/k
};

class SetpointShaper {
 public:
  SetpointShaper() { set_params(ShaperParams{}); }
  explicit SetpointShaper(const ShaperParams& p) { set_params(p); }

  void set_params(const ShaperParams& p);
  const ShaperParams& params() const { return params_; }

  // Puts the reference at p, at rest, with the target there too.
  void reset(const Vec3& p);
  void set_target(const Vec3& target) {
    if (memcmp(&target, &target_, sizeof target) == 0) return;  // the same target again: keep holding
    target_ = target;
    holding_ = false;
  }
  const Vec3& target() const { return target_; }

  // Advances the reference by dt seconds and writes it into sp.p_d, sp.v_d, sp.a_d.
  void update(float dt, PositionSetpoint& sp);

  const Vec3& position() const { return p_; }
  const Vec3& velocity() const { return v_; }
  bool arrived(float tolerance) const;  // within tolerance (m) of the target and nearly at rest
  bool holding() const { return holding_; }  // at rest on the target: update() has nothing to compute

 private:
  ShaperParams params_;
  float linear_dist_ = 0.0f;  // max_accel / k^2: below it the approach speed is linear in the distance
  float cruise_dist_ = 0.0f;  // beyond it the approach speed is max_speed (no square root needed)
  float dt_ = 0.0f;           // the last step and its inverse, so a constant rate costs no division
  float inv_dt_ = 0.0f;
  Vec3 target_;
  Vec3 p_;
  Vec3 v_;
  // At rest (v exactly zero) within a micrometre of the target: a step would give a = 0 and change
  // nothing, so update() skips it until the target or the state is set again.
  bool holding_ = false;
};

// Returns nullptr when usable, else the name of the first bad field.
const char* validate(const ShaperParams& p);

}  // namespace ctrl
}  // namespace quad
