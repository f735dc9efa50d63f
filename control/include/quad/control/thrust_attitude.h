// Thrust and desired attitude from the desired virtual acceleration, thesis eq. 8.28-8.37 with the errata
// applied, composed with the desired heading:
//   T   = m ||g e_z - mu_d||                                   (eq. 8.30)
//   u   = (g e_z - mu_d) / ||g e_z - mu_d||,  R_d e_3 = u      (eq. 8.28/8.32 with R_d = R_IB)
//   Q_tilt: q0 = sqrt((1 + u_z) / 2),  q = (mu_d2, -mu_d1, 0) / (2 N q0)   (eq. 8.37a/b, corrected)
//   Q_d = Q_tilt (x) Q_yaw(yaw_d)                               (errata "8.37 yaw")
// Thrust acts along body -z (FRD), so R_d (-e_3) points along mu_d - g e_z: the commanded specific force.
//
// Limits, applied to mu_d before the formulas so the result is always well defined:
//   1. vertical: g - mu_d3 >= min_thrust / m (the thrust never points down, which also keeps eq. 8.37
//      away from its singularity u = -e_z) and <= max_thrust / m;
//   2. tilt: the horizontal part of mu_d is scaled down so the tilt stays <= max_tilt;
//   3. total thrust: if T would exceed max_thrust the horizontal part is scaled down further (altitude
//      has priority over horizontal acceleration).
// The heading of Q_d's body x axis equals yaw_d exactly when level and to second order in the tilt.
//
// Usage:
//   quad::ctrl::ThrustAttitude ta;                         // defaults: Quad-C, 35 deg, thrust range
//   ta.set_params(quad::ctrl::ThrustAttitudeParams::for_vehicle(vehicle));
//   quad::ctrl::AttitudeCommand cmd = ta.update(mu_d, yaw_d);   // cmd.thrust (N), cmd.q_d
#pragma once

#include "quad/control/vehicle.h"
#include "quad/math/math.h"

namespace quad {
namespace ctrl {

struct ThrustAttitudeParams {
  float mass = 1.4f;                   // kg
  float max_tilt = 35.0f * kDegToRad;  // rad, in (0, 80 deg]
  float min_thrust = 0.1f * 1.4f * kGravity;  // N: keeps the vehicle upright and controllable
  float max_thrust = 4.0f * 0.880f * kGravity;  // N: what the four motors can give

  // mass and maximum thrust from the vehicle; min_thrust 10 % of hover.
  static ThrustAttitudeParams for_vehicle(const VehicleParams& v);
};

// What the attitude loop and the mixer need: collective thrust and desired attitude.
struct AttitudeCommand {
  float thrust = 0.0f;       // N, along body -z
  Quat q_d;                  // desired attitude q_IB
  Vec3 mu_applied;           // the mu_d actually realised after the limits, m/s^2 (NED)
  bool limited = false;      // true when any limit changed mu_d
};

class ThrustAttitude {
 public:
  ThrustAttitude();
  explicit ThrustAttitude(const ThrustAttitudeParams& p);
  // Leaves the precomputed values unset, for an owner that calls set_params() before any use (Cascade,
  // whose configure() always ends with valid parameters).
  struct Unset {};
  explicit ThrustAttitude(Unset) {}

  // Precomputes tan(max_tilt) and the thrust bounds in m/s^2; call when parameters change.
  void set_params(const ThrustAttitudeParams& p);
  const ThrustAttitudeParams& params() const { return params_; }

  // T and Q_d for the desired virtual acceleration mu_d (NED, m/s^2) and heading yaw_d (rad).
  // Non-finite input yields a level, hover-thrust command with limited = true.
  AttitudeCommand update(const Vec3& mu_d, float yaw_d);
  // The same into `cmd` (every field written): no copy of the result (Cascade).
  void update(const Vec3& mu_d, float yaw_d, AttitudeCommand& cmd);

 private:
  Quat yaw_quat(float yaw_d);  // cached: the trigonometry runs only when yaw_d changes
  void command_within_limits(float h_x, float h_y, float h_sq, float a_z, float a_z_sq, const Quat& yaw,
                             AttitudeCommand& cmd) const;
  void command_at_tilt_limit(float h_x, float h_y, float h_sq, float a_z, float tilt_cap, const Quat& yaw,
                             AttitudeCommand& cmd) const;
  static void compose(float p_x, float p_y, float w_c, float w_s, float k_c, float k_s, float h_x, float h_y, float a_z,
                      AttitudeCommand& cmd);

  // (No member initialisers: set_params() sets them all, and every constructor but the Unset one calls it.)
  ThrustAttitudeParams params_;
  float tan_max_tilt_;
  float min_accel_;  // min_thrust / m
  float max_accel_;  // max_thrust / m
  float max_accel_sq_;
  // A sufficient condition for limits 2 and 3 not to act, tested first (three integer comparisons
  // instead of three multiplications, one addition and three comparisons): a_z >= g/2,
  // a_z^2 <= free_az_sq_ and |h|^2 <= free_h_sq_. free_h_sq_ is the tilt cap at a_z = g/2,
  // (tan(max_tilt) g/2)^2, and free_az_sq_ an a_z^2 whose thrust cap max_accel^2 - a_z^2 still covers
  // it, both as the float operations of update() round them, so the shortcut never skips a limit that
  // would act: it decides exactly as the full test.
  float free_h_sq_;
  float free_az_sq_;
  // At the tilt limit: cos and sin of max_tilt / 2, and 1 / cos(max_tilt).
  float tilt_cos_half_;
  float tilt_sin_half_;
  float inv_cos_tilt_;
  float cached_yaw_;
  Quat cached_yaw_quat_;
};

// Returns nullptr when usable, else the name of the first bad field.
const char* validate(const ThrustAttitudeParams& p);

}  // namespace ctrl
}  // namespace quad
