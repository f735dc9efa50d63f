// Hover trim: removes the steady vertical offset of the position controller.
//
// Thesis eq. 8.20 is a PD law, mu_d = a_d - K_p tanh(p - p_d) - K_v tanh(v - v_d), so any mismatch
// between the thrust the controller believes it commands and the thrust the vehicle makes (mass, motor
// curve, battery sag: about 2 % in HIL) leaves a constant height error of about g * mismatch / K_p,z
// (6 cm in HIL, 13.5 cm for a 5 % heavier vehicle). This adds the missing integral action outside the
// control library, as an acceleration feed-forward on a_d,z:
//   a_trim = -K_i,z * integral of (p_z - p_d,z) dt,   clamped to |a_trim| <= POS_I_MAX_Z (anti-windup:
//   the integral stops growing at the limit)
// With table 8.1's K_p,z = 3.625 and K_v,z = 3.5 the loop s^3 + K_v s^2 + K_p s + K_i stays stable for
// K_i < K_v K_p = 12.7 (Routh); POS_KI_Z = 1 puts the poles at -0.44, -1.29 and -1.78 1/s, so the offset
// decays with a time constant of about 2.3 s. The integrator runs only while airborne in AUTO (on the ground
// the error means nothing) and the trim is kept, frozen, while landing; it starts from zero at arming.
#pragma once

namespace quad {
namespace fw {

class HoverTrim {
 public:
  // ki: POS_KI_Z (1/s^2 per m, 0 turns the trim off); limit: POS_I_MAX_Z (m/s^2).
  void configure(float ki, float limit);
  void reset() { accel_ = 0.0f; }

  // One step with the vertical position error p_z - p_d,z (NED, m) over dt seconds.
  void update(float position_error_z, float dt);

  // The acceleration feed-forward to add to a_d,z (NED, m/s^2; negative = more thrust).
  float accel() const { return accel_; }

 private:
  float ki_ = 0.0f;
  float limit_ = 0.0f;
  float accel_ = 0.0f;
};

}  // namespace fw
}  // namespace quad
