// The HIL link's messages (docs/hil-protocol.md) as the single-vehicle run (hil_session.h) and the fleet
// run (fleet_session.h) both build and read them: the ids the simulator sends with, the HIL_SENSOR of a
// sample, the ground station's message for a scenario command, the firmware's mode from its HEARTBEAT.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "quad/link/mavlink.h"
#include "quad/sim/imu.h"
#include "quad/sim/scenario.h"

namespace quad::sim {

// Every firmware is system 1 on its own link (quad/link/dialect.h).
constexpr uint8_t kVehicleSys = 1;
constexpr uint8_t kSimComp = 200;
constexpr uint8_t kGcsSys = 255;

// Simulated seconds as a link time stamp (microseconds).
inline uint64_t to_usec(double t) { return static_cast<uint64_t>(std::llround(t * 1e6)); }

// HIL_SENSOR at t: accelerometer and gyroscope always, the magnetometer's fields flagged only when it
// has a new reading (`mag_fresh`).
mavlink::HilSensor hil_sensor_message(double t, const ImuReading& imu, const Eigen::Vector3d& mag, bool mag_fresh);

// SET_POSITION_TARGET_LOCAL_NED for a command with `setpoint_ned_m`, sent at t: position and yaw only.
mavlink::SetPositionTargetLocalNed setpoint_message(const GcsCommand& c, double t);

// COMMAND_LONG for an arm, disarm, mode or land command (land for any other), and its name in
// events.log ("arm", "mode AUTO", "land").
struct CommandMessage {
  mavlink::CommandLong message;
  std::string what;
};
CommandMessage command_long_message(const GcsCommand& c);

// The firmware's flight mode and armed state as its HEARTBEATs report them (mode -1: none heard yet).
struct HeartbeatState {
  int mode = -1;
  bool armed = false;
  // Takes the HEARTBEAT's mode and armed state; true when either changed.
  bool update(const mavlink::Heartbeat& m);
  // "mode AUTO, armed", as events.log says it.
  std::string text() const;
  // The mode's name, "-" before the first HEARTBEAT.
  std::string mode_name() const;
};

}  // namespace quad::sim
