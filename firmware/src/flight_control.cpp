#include "quad/firmware/flight_control.h"

#include "quad/firmware/app_checks.h"
#include "quad/firmware/param_fields.h"
#include "quad/math/float_bits.h"

namespace quad {
namespace fw {

namespace {

inline ctrl::ManualParams manual_params(const Params& p, float max_total_thrust) {
  ctrl::ManualParams mp;
  load_fields(p, mp, kManualFields);
  mp.max_thrust = p.get(kManThrMax) * max_total_thrust;
  mp.dead_band = static_cast<uint16_t>(p.get(kManDeadband));
  return mp;
}

inline ctrl::ShaperParams shaper_params(const Params& p) {
  ctrl::ShaperParams sp;
  load_fields(p, sp, kShaperFields);
  return sp;
}

inline ctrl::CascadeParams cascade_params(const Params& p) {
  ctrl::CascadeParams cp;
  load_fields(p, cp, kCascadeFields);
  cp.vehicle.frame = p.get(kVehFrame) >= 0.5f ? ctrl::Frame::kX : ctrl::Frame::kPlus;
  cp.vehicle.yaw_coeff = p.get(kVehYawK) * p.get(kVehThrCoef);
  return cp;
}

}  // namespace

bool RcSwitchEdges::update(const RcSwitches& now, RcSwitches* before) {
  *before = switches_;
  switches_ = now;
  if (known_) return true;
  known_ = true;
  return false;
}

const char* FlightControl::configure(const Params& p) {
  const ctrl::CascadeParams cp = cascade_params(p);
  const ctrl::ManualParams mp = manual_params(p, cp.vehicle.max_total_thrust());
  const ctrl::ShaperParams sp = shaper_params(p);
  const char* bad = ctrl::validate(mp);
  if (bad == nullptr) bad = ctrl::validate(sp);
  if (bad != nullptr) return bad;
  // Cascade::configure() checks the combination last and keeps the old parameters when it refuses it.
  const ctrl::ParamError e = cascade_.configure(cp);
  if (!e.ok()) return e.field;
  manual_.set_params(mp);
  shaper_.set_params(sp);
  // Every field given (no default-initialised ModeConfig to copy from RAM on the AVR).
  const ModeConfig mc{p.get(kFsVisTimeout), p.get(kFsRcTimeout), p.get(kFsRcEnable) >= 0.5f, p.get(kArmThrMax)};
  modes_.configure(mc);
  rc_switches_enabled_ = p.get(kRcSwitches) >= 0.5f;
  trim_.configure(p.get(kPosKiXY), p.get(kPosIMaxXY), p.get(kPosKiZ), p.get(kPosIMaxZ));
  land_speed_ = p.get(kLandSpeed);
  land_vz_max_ = p.get(kLandVzMax);
  land_time_s_ = p.get(kLandTime);
  land_thrust_max_ = p.get(kLandThrFrac) * cp.vehicle.hover_thrust();
  star_view_height_ = p.get(kLandVisHgt);
  return nullptr;
}

void FlightControl::set_sticks(const ctrl::RcSticks& sticks, uint32_t t_us) {
  sticks_ = sticks;
  rc_seen_ = true;
  rc_time_us_ = t_us;
}

void FlightControl::enter_mode(FlightMode from, FlightMode to, const Vec3& position, float yaw) {
  switch (to) {
    case FlightMode::kDisarmed:
      landed_ = true;
      break;
    case FlightMode::kManual:
      manual_.reset(yaw);
      if (from == FlightMode::kDisarmed) {
        landed_ = true;
        trim_.reset();
      }
      break;
    case FlightMode::kAuto:
      // Hold where the vehicle is; setpoints from the ground station move the target from here.
      shaper_.reset(position);
      shaper_.set_target(position);
      // What the shaper gives at rest on its target (p_d = p, v_d = a_d = 0), so a position loop that
      // runs before the shaper's next step (above 100 Hz) holds here.
      setpoint_ = ctrl::PositionSetpoint{};
      setpoint_.p_d = position;
      setpoint_.yaw_d = yaw;
      break;
    case FlightMode::kLanding:
      setpoint_.p_d = position;
      setpoint_.yaw_d = yaw;
      landed_for_s_ = 0.0f;
      break;
  }
}

void FlightControl::step(const ctrl::VehicleState& s, float dt, const IterationPlan& plan) {
  // The position loop in its own iteration of a faster loop (every iteration at 100 Hz), and at once in
  // the first iteration of a mode that uses it.
  const FlightMode mode = modes_.mode();
  const bool position_loop = plan.position_loop || mode != last_mode_;
  last_mode_ = mode;

  const ctrl::CascadeOutput* out = nullptr;
  switch (mode) {
    case FlightMode::kDisarmed:
      break;
    case FlightMode::kManual:
      manual_.update(sticks_, dt);
      out = &cascade_.step_attitude(s, manual_.command());
      break;
    case FlightMode::kAuto:
      out = fly_auto(s, plan, position_loop);
      break;
    case FlightMode::kLanding:
      if (position_loop) out = fly_landing(s);
      break;
  }
  // Between two runs of the position loop the attitude loop flies its last thrust and attitude.
  if (out == nullptr && !position_loop && (mode == FlightMode::kAuto || mode == FlightMode::kLanding)) {
    out = &cascade_.step_held(s);
  }
  if (out == nullptr) {
    for (float& m : motors_) m = 0.0f;
    last_thrust_ = 0.0f;
    return;
  }
  for (uint8_t i = 0; i < hal::kMotorCount; ++i) motors_[i] = out->motors.command[i];
  last_thrust_ = out->attitude.thrust;
}

const ctrl::CascadeOutput* FlightControl::fly_auto(const ctrl::VehicleState& s, const IterationPlan& plan,
                                                   bool position_loop) {
  if (plan.frame_work) {
    shaper_.update(plan.frame_dt, setpoint_);
    // The trim learns only in the air (on the ground the error is the ground's doing), and not along an
    // axis the shaped setpoint is moving on (a move's tracking lag is not an offset).
    if (!landed_) {
      const uint8_t moving = moving_axes(setpoint_.v_d);
      const bool learn[3] = {(moving & 1u) == 0u, (moving & 2u) == 0u, (moving & 4u) == 0u};
      trim_.update(s.p - setpoint_.p_d, learn, plan.frame_dt);
    }
  }
  if (!position_loop) return nullptr;
  ctrl::PositionSetpoint sp = setpoint_;
  sp.a_d += trim_.accel();
  return &cascade_.step(s, sp);
}

const ctrl::CascadeOutput* FlightControl::fly_landing(const ctrl::VehicleState& s) {
  // Holding position: the horizontal target stays where the landing began. Level: the horizontal errors
  // are zeroed, so eq. 8.20 asks for no horizontal acceleration and the attitude stays level (no trust
  // in a position without vision).
  ctrl::PositionSetpoint sp = setpoint_;
  sp.p_d.z = s.p.z;
  sp.v_d = Vec3{0.0f, 0.0f, land_speed_};
  sp.a_d = Vec3{0.0f, 0.0f, trim_.accel_z()};  // the learned vertical trim, frozen
  if (modes_.land_level()) {
    sp.p_d.x = s.p.x;
    sp.p_d.y = s.p.y;
    sp.v_d.x = s.v.x;
    sp.v_d.y = s.v.y;
  }
  return &cascade_.step(s, sp);
}

void FlightControl::detect_landing(float dt, float v_z) {
  if (!modes_.armed()) {
    landed_ = true;
    landed_for_s_ = 0.0f;
    return;
  }
  // On the ground the commanded descent cannot happen: the estimated vertical speed stays near zero
  // while the controller, pushing down, asks for clearly less than hover thrust (the hover thrust the
  // trim has learned: a_trim < 0, up, means the vehicle needs more than the model).
  // (LAND_VZ_MAX >= 0.05 by its range: abs_below() compares the patterns, float_bits.h.)
  bool on_ground = abs_below(v_z, land_vz_max_);
  if (on_ground) {
    const float hover_scale = 1.0f - trim_.accel_z() * (1.0f / kGravity);
    on_ground = last_thrust_ < land_thrust_max_ * hover_scale;
  }
  landed_for_s_ = on_ground ? landed_for_s_ + dt : 0.0f;
  if (landed_for_s_ >= land_time_s_) landed_ = true;
  else if (!on_ground) landed_ = false;
}

bool FlightControl::hovering(const Vec3& v) const {
  if (modes_.mode() != FlightMode::kAuto || landed_) return false;
  if (moving_axes(setpoint_.v_d) != 0u) return false;
  return slow_for_hover(v);
}

}  // namespace fw
}  // namespace quad
