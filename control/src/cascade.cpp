#include "quad/control/cascade.h"

namespace quad {
namespace ctrl {

namespace {

ThrustAttitudeParams thrust_attitude_params(const CascadeParams& p) {
  ThrustAttitudeParams t = ThrustAttitudeParams::for_vehicle(p.vehicle);
  t.max_tilt = p.max_tilt;
  return t;
}

ParamError check(const CascadeParams& p) {
  ParamError e;
  if ((e.field = validate(p.vehicle)) != nullptr) {
    e.group = "vehicle";
  } else if ((e.field = validate(p.position)) != nullptr) {
    e.group = "position";
  } else if ((e.field = validate(p.attitude)) != nullptr) {
    e.group = "attitude";
  } else if ((e.field = validate(thrust_attitude_params(p))) != nullptr) {
    e.group = "thrust_attitude";
  }
  return e;
}

}  // namespace

// The pieces are left unset and configured once here (configure() with the defaults always succeeds).
Cascade::Cascade() : thrust_attitude_(ThrustAttitude::Unset{}), mixer_(Mixer::Unset{}) { configure(CascadeParams{}); }

Cascade::Cascade(const CascadeParams& p) : thrust_attitude_(ThrustAttitude::Unset{}), mixer_(Mixer::Unset{}) {
  if (!configure(p).ok()) configure(CascadeParams{});
}

ParamError Cascade::configure(const CascadeParams& p) {
  const ParamError e = check(p);
  if (!e.ok()) return e;
  params_ = p;
  position_.set_gains(p.position);
  thrust_attitude_.set_params(thrust_attitude_params(p));
  attitude_.set_gains(p.attitude);
  mixer_.set_vehicle(p.vehicle);
  return e;
}

const CascadeOutput& Cascade::step(const VehicleState& s, const PositionSetpoint& sp) {
  out_.mu_d = position_.update(sp, s.p, s.v);                   // thesis eq. 8.20
  thrust_attitude_.update(out_.mu_d, sp.yaw_d, out_.attitude);  // thesis eq. 8.30, 8.37
  out_.torque = attitude_.update(s.q, s.omega, out_.attitude.q_d);  // thesis eq. 8.38/8.39
  mixer_.mix(out_.attitude.thrust, out_.torque, out_.motors);   // thesis eq. 5.8
  return out_;
}

const CascadeOutput& Cascade::step_held(const VehicleState& s) {
  out_.torque = attitude_.update(s.q, s.omega, out_.attitude.q_d);  // thesis eq. 8.38/8.39
  mixer_.mix(out_.attitude.thrust, out_.torque, out_.motors);       // thesis eq. 5.8
  return out_;
}

const CascadeOutput& Cascade::step_attitude(const VehicleState& s, const AttitudeCommand& cmd) {
  out_.mu_d = Vec3{};
  out_.attitude = cmd;
  out_.torque = attitude_.update(s.q, s.omega, cmd.q_d);
  mixer_.mix(cmd.thrust, out_.torque, out_.motors);
  return out_;
}

}  // namespace ctrl
}  // namespace quad
