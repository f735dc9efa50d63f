// Flight control: the flight modes and failsafes, the setpoints (RC sticks in MANUAL, the shaped position
// setpoint in AUTO, the descent in LANDING), the position trim, the control cascade (thesis eq.
// 8.20-8.40), the motor mixer and the landing detector.
//
// It knows no MAVLink: the application hands it the state estimate, the iteration's plan
// (frame_schedule.h), the pilot's and the ground station's inputs, and reports the mode transitions.
#pragma once

#include <stdint.h>

#include "quad/control/cascade.h"
#include "quad/control/manual.h"
#include "quad/control/setpoint_shaper.h"
#include "quad/firmware/frame_schedule.h"
#include "quad/math/float_bits.h"
#include "quad/firmware/modes.h"
#include "quad/firmware/params.h"
#include "quad/firmware/position_trim.h"
#include "quad/hal/hal.h"

namespace quad {
namespace fw {

// The toggle switches of the RC transmitter (thesis sec. 6.1.4: 1000 or 2000 us).
struct RcSwitches {
  bool motors_enabled = false;
  bool auto_mode = false;
};

// The transitions of the two switches: a transmitter switched on with "motors enabled" does not arm the
// vehicle, so the first frame only records where they stand.
class RcSwitchEdges {
 public:
  // The switches now; false for the first frame (no transition yet).
  bool update(const RcSwitches& now, RcSwitches* before);

 private:
  RcSwitches switches_;
  bool known_ = false;
};

class FlightControl {
 public:
  // Takes p, or returns the name of the offending parameter and keeps what it had.
  const char* configure(const Params& p);

  // The RC sticks at t_us (a pulse outside the receiver's range keeps the previous command).
  void set_sticks(const ctrl::RcSticks& sticks, uint32_t t_us);
  bool rc_seen() const { return rc_seen_; }
  uint32_t rc_time_us() const { return rc_time_us_; }
  float rc_throttle() const { return ctrl::throttle_to_unit(sticks_.throttle); }
  bool rc_switches_enabled() const { return rc_switches_enabled_; }

  // A position target from the ground station (AUTO's shaper moves to it), and the heading to hold.
  void set_position_target(const Vec3& target) { shaper_.set_target(target); }
  void set_yaw_target(float yaw) { setpoint_.yaw_d = wrap_pi(yaw); }

  // The mode machine (modes.h): commands, failsafes, and what entering a mode sets up, from the estimate.
  Transition command(Command c, const ModeInputs& in) { return modes_.command(c, in); }
  Transition update_mode(const ModeInputs& in) { return modes_.update(in); }
  void enter_mode(FlightMode from, FlightMode to, const Vec3& position, float yaw);

  // One iteration: the motor commands for state s, dt after the last.
  void step(const ctrl::VehicleState& s, float dt, const IterationPlan& plan);
  // The landing detector, in the frame-rate work's iteration (dt: the frame's time; v_z: the estimate's).
  void detect_landing(float dt, float v_z);
  // Hovering still in AUTO: airborne, the shaped setpoint at rest and the vehicle slow (velocity v), so
  // the mean horizontal specific force is the accelerometer's bias (hover_accel_bias.h).
  bool hovering(const Vec3& v) const;

  FlightMode mode() const { return modes_.mode(); }
  // The mode changed since the last iteration: the next one runs the position loop whatever its stage.
  bool mode_entered() const { return modes_.mode() != last_mode_; }
  bool armed() const { return modes_.armed(); }
  bool land_level() const { return modes_.land_level(); }
  bool vision_fresh(const ModeInputs& in) const { return modes_.vision_fresh(in); }
  bool rc_fresh(const ModeInputs& in) const { return modes_.rc_fresh(in); }
  bool landed() const { return landed_; }
  // Landed, or the land detector's quiet condition holds (|v_z| small, thrust below LAND_THR_FRAC of
  // hover) while it waits LAND_TIME to be sure: the vehicle may stand on the ground.
  // (On the bit pattern, with the ground hold's, the filter's gap and fold tests and the clip guard's
  // quiet time, which every iteration or prediction makes: float_bits.h, 190 cycles off the median 200 Hz
  // PIL iteration.)
  bool on_ground() const { return landed_ || positive(landed_for_s_); }
  // LAND_VIS_HGT: below this height above the star a landing loses it by design (modes.h).
  float star_view_height() const { return star_view_height_; }
  const float (&motors() const)[hal::kMotorCount] { return motors_; }
  // The position setpoint the mode set (AUTO: the shaper's; LANDING: where the descent started).
  const ctrl::PositionSetpoint& setpoint() const { return setpoint_; }
  Vec3 position_trim() const { return trim_.accel(); }
  float hover_trim() const { return trim_.accel_z(); }

 private:
  // AUTO: the shaper in the frame-rate work, the trim learning in the air, the position loop when due.
  const ctrl::CascadeOutput* fly_auto(const ctrl::VehicleState& s, const IterationPlan& plan, bool position_loop);
  // LANDING: a descent at LAND_SPEED, holding the horizontal position or (without vision) level.
  const ctrl::CascadeOutput* fly_landing(const ctrl::VehicleState& s);

  ModeMachine modes_;
  ctrl::Cascade cascade_;
  ctrl::ManualControl manual_;
  ctrl::SetpointShaper shaper_;
  ctrl::PositionSetpoint setpoint_;
  PositionTrim trim_;
  ctrl::RcSticks sticks_;
  bool rc_seen_ = false;
  uint32_t rc_time_us_ = 0;
  bool rc_switches_enabled_ = false;
  // The mode of the last iteration: a different one runs the position loop at once, so the attitude loop
  // never flies another mode's command.
  FlightMode last_mode_ = FlightMode::kDisarmed;
  float land_speed_ = 0.0f;       // LAND_SPEED, m/s down
  float land_vz_max_ = 0.0f;      // LAND_VZ_MAX, m/s
  float land_time_s_ = 0.0f;      // LAND_TIME
  float land_thrust_max_ = 0.0f;  // N: LAND_THR_FRAC of the hover thrust
  float star_view_height_ = 0.0f; // LAND_VIS_HGT, m
  float landed_for_s_ = 0.0f;
  bool landed_ = true;
  float motors_[hal::kMotorCount] = {0.0f, 0.0f, 0.0f, 0.0f};
  float last_thrust_ = 0.0f;
};

}  // namespace fw
}  // namespace quad
