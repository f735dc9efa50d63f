#include "quad/sim/hil_messages.h"

#include "quad/sim/flight_modes.h"

namespace quad::sim {
namespace mav = quad::mavlink;

namespace {

// SET_POSITION_TARGET_LOCAL_NED type_mask: use position and yaw, ignore velocity, acceleration, yaw rate.
constexpr uint16_t kPositionAndYawOnly = 0x0008 | 0x0010 | 0x0020 | 0x0040 | 0x0080 | 0x0100 | 0x0800;

}  // namespace

mav::HilSensor hil_sensor_message(double t, const ImuReading& imu, const Eigen::Vector3d& mag, bool mag_fresh) {
  mav::HilSensor m;
  m.time_usec = to_usec(t);
  m.xacc = static_cast<float>(imu.specific_force_frd.x());
  m.yacc = static_cast<float>(imu.specific_force_frd.y());
  m.zacc = static_cast<float>(imu.specific_force_frd.z());
  m.xgyro = static_cast<float>(imu.rate_frd.x());
  m.ygyro = static_cast<float>(imu.rate_frd.y());
  m.zgyro = static_cast<float>(imu.rate_frd.z());
  m.xmag = static_cast<float>(mag.x());
  m.ymag = static_cast<float>(mag.y());
  m.zmag = static_cast<float>(mag.z());
  m.fields_updated = 0x3Fu | (mag_fresh ? 0x1C0u : 0u);  // accel bits 0-2, gyro 3-5, mag 6-8
  m.id = 0;
  return m;
}

mav::SetPositionTargetLocalNed setpoint_message(const GcsCommand& c, double t) {
  mav::SetPositionTargetLocalNed sp;
  sp.time_boot_ms = static_cast<uint32_t>(t * 1000.0);
  sp.x = static_cast<float>(c.setpoint_ned_m->x());
  sp.y = static_cast<float>(c.setpoint_ned_m->y());
  sp.z = static_cast<float>(c.setpoint_ned_m->z());
  sp.yaw = static_cast<float>(c.yaw_rad);
  sp.type_mask = kPositionAndYawOnly;
  sp.target_system = kVehicleSys;
  sp.target_component = mav::kCompIdAutopilot1;
  sp.coordinate_frame = mav::kFrameLocalNed;
  return sp;
}

CommandMessage command_long_message(const GcsCommand& c) {
  CommandMessage out;
  mav::CommandLong& cmd = out.message;
  cmd.target_system = kVehicleSys;
  cmd.target_component = mav::kCompIdAutopilot1;
  if (c.arm) {
    cmd.command = mav::kCmdComponentArmDisarm;
    cmd.param1 = *c.arm ? 1.0f : 0.0f;
    out.what = *c.arm ? "arm" : "disarm";
  } else if (c.mode) {
    cmd.command = mav::kCmdDoSetMode;
    cmd.param1 = mav::kModeFlagCustomModeEnabled;
    cmd.param2 = static_cast<float>(*c.mode);
    out.what = "mode " + flight_mode_name(*c.mode);
  } else {
    cmd.command = mav::kCmdNavLand;
    out.what = "land";
  }
  return out;
}

bool HeartbeatState::update(const mav::Heartbeat& m) {
  const int new_mode = static_cast<int>(m.custom_mode);
  const bool new_armed = (m.base_mode & mav::kModeFlagSafetyArmed) != 0;
  const bool changed = new_mode != mode || new_armed != armed;
  mode = new_mode;
  armed = new_armed;
  return changed;
}

std::string HeartbeatState::text() const { return "mode " + flight_mode_name(mode) + (armed ? ", armed" : ", disarmed"); }

std::string HeartbeatState::mode_name() const { return mode < 0 ? "-" : flight_mode_name(mode); }

}  // namespace quad::sim
