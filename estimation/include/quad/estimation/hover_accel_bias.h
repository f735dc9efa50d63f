// In-flight accelerometer bias on the body x and y axes, learned while hovering.
//
// Why: the boot calibration (thesis eq. 7.2) removes the accelerometer bias at boot, but the bias keeps
// drifting (the MPU-6000's bias random walk, reference-facts: 6e-3 m/s^2/sqrt(s), about 0.05 m/s^2 in a
// minute). The attitude observer takes a horizontal bias b for a tilt of b/g (eq. 4.7 aligns the
// measured specific force with gravity), and the vision fix, rotated into NED with that attitude
// (eq. 8.5), then places the vehicle h b/g off where it is: 0.8 cm at 1.5 m for 0.05 m/s^2. In steady
// hover the tilt error cannot be seen from the attitude sensors alone (a bias and a tilt give the same
// specific force) and the single star's fix trades a tilt for a shift.
//
// What makes it observable: a rotor's thrust acts along the body z axis, so the specific force of a
// quadrotor has no body x/y component but aerodynamic drag (Martin and Salaun 2010; Leishman et al.
// 2014). Hovering still indoors, drag is zero on average, so the mean of the accelerometer's x and y
// readings is their bias. This tracker low-passes them with time constant tau while the caller says the
// vehicle hovers (airborne, setpoint at rest, slow), and holds the estimate otherwise.
//
// Limit: a steady wind's drag is a real horizontal specific force (the vehicle leans into it), which
// this would take for bias; the estimate is therefore clamped to +-limit, the bias drift a flight can
// accumulate (0.15 m/s^2: the random walk's 1-sigma after 10 min), so that in wind the attitude error it
// can cause is at most limit/g (0.9 deg). z is not learned (thrust is along z; the position filter's
// optional z bias state covers it).
#pragma once

#include "quad/math/math.h"

namespace quad {
namespace est {

class HoverAccelBias {
 public:
  // tau_s: time constant of the mean (s; 0 turns the tracker off and clears it); limit: m/s^2 per axis.
  void configure(float tau_s, float limit);
  void reset() { bx_ = by_ = 0.0f; }

  // One accelerometer sample (specific force, FRD, m/s^2, boot-calibrated) over dt seconds; learns
  // only when `hovering`.
  void update(const Vec3& accel_frd, bool hovering, float dt);

  // The learned bias (FRD, m/s^2; z is always zero): subtract it from the accelerometer.
  Vec3 bias() const { return {bx_, by_, 0.0f}; }

 private:
  float inv_tau_ = 0.0f;
  float limit_ = 0.0f;
  float bx_ = 0.0f, by_ = 0.0f;  // x and y only (RAM: the ATmega2560's scarcest resource)
};

}  // namespace est
}  // namespace quad
