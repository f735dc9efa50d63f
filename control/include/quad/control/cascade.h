// The whole position-control chain of thesis fig. 8.1 in one call, for the firmware and the benchmark:
//   position controller (eq. 8.20) -> thrust and desired attitude (eq. 8.28-8.37) -> attitude PD
//   (eq. 8.38/8.39) -> mixer (eq. 5.8).
// The pieces stay usable on their own (see their headers); this class only owns one of each and wires
// them. step_attitude() starts at the attitude loop: for manual flight (ManualControl::command()), and
// for running the attitude loop faster than the position loop, step_held() (step() at the position
// rate, step_held() in between, as the firmware does above 100 Hz: on the ATmega2560 step() costs
// about 24 000 cycles near hover, the attitude loop and mixer about 11 000; docs/performance.md).
//
// Usage:
//   quad::ctrl::CascadeParams params;                     // Quad-C, table 8.1 gains, 35 deg tilt
//   quad::ctrl::Cascade cascade(params);
//   quad::ctrl::VehicleState s{p, v, q, omega};           // from the estimators
//   const quad::ctrl::CascadeOutput& out = cascade.step(s, setpoint);
//   send(out.motors.command);                             // 4 commands in [0, 1], vehicle.h order
#pragma once

#include "quad/control/attitude_controller.h"
#include "quad/control/mixer.h"
#include "quad/control/position_controller.h"
#include "quad/control/thrust_attitude.h"
#include "quad/control/vehicle.h"
#include "quad/math/math.h"

namespace quad {
namespace ctrl {

struct CascadeParams {
  VehicleParams vehicle;
  PositionGains position;
  AttitudeGains attitude;
  float max_tilt = 35.0f * kDegToRad;  // rad
};

// Which parameter was rejected: group ("vehicle", "position", "attitude", "thrust_attitude") and field.
struct ParamError {
  const char* group = nullptr;
  const char* field = nullptr;
  bool ok() const { return field == nullptr; }
};

// The estimated state: NED position and velocity, attitude q_IB, body rate (FRD).
struct VehicleState {
  Vec3 p;
  Vec3 v;
  Quat q;
  Vec3 omega;
};

struct CascadeOutput {
  Vec3 mu_d;                // eq. 8.20 before the limits, m/s^2
  AttitudeCommand attitude; // thrust and Q_d (after the limits)
  Vec3 torque;              // eq. 8.39, N m
  MixerOutput motors;       // eq. 5.8 and the motor commands
};

class Cascade {
 public:
  Cascade();
  // Falls back to the defaults if `p` is rejected; call configure() to learn which field was bad.
  explicit Cascade(const CascadeParams& p);

  // Precomputes what every piece needs. If a parameter is unusable, nothing changes and the result
  // names it (e.g. {"vehicle", "mass"}; ok() is true when all were accepted).
  ParamError configure(const CascadeParams& p);
  const CascadeParams& params() const { return params_; }

  // One full step from the position setpoint.
  const CascadeOutput& step(const VehicleState& s, const PositionSetpoint& sp);

  // From a thrust and attitude command (manual flight): attitude loop and mixer only. mu_d is zero.
  const CascadeOutput& step_attitude(const VehicleState& s, const AttitudeCommand& cmd);
  // Between two step()s of a position loop slower than the attitude loop: attitude loop and mixer on
  // the last step()'s thrust and attitude (zero-order hold); mu_d and the command stay as they were.
  const CascadeOutput& step_held(const VehicleState& s);

  const CascadeOutput& output() const { return out_; }

 private:
  CascadeParams params_;
  PositionController position_;
  ThrustAttitude thrust_attitude_;
  AttitudeController attitude_;
  Mixer mixer_;
  CascadeOutput out_;
};

}  // namespace ctrl
}  // namespace quad
