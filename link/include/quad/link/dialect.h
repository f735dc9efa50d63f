// The project's MAVLink dialect: what the vehicle, the simulator, the vision station and the ground tool
// agree on beyond the codec's common messages (messages.h). Header only, freestanding, so every side
// includes the same definitions instead of linking the firmware.
//
//   - the vehicle's system and component ids;
//   - the flight modes: HEARTBEAT.custom_mode and MAV_CMD_DO_SET_MODE param2 numbers, and their names;
//   - SETUP_SIGNING (MAVLink common, id 256), which only the vehicle and the ground station speak, and the
//     project's own LANDING_TARGET_COVARIANCE and EXTERNAL_POSE_TARGETED (dialect_pose.h): the parsers
//     that must recognise them use dialect_message_info() instead of the codec's table. Id, CRC_EXTRA and
//     layout are those of node-mavlink 2.3's mavlink-mappings (SetupSigning: MSG_ID 256,
//     MAGIC_NUMBER 71, PAYLOAD_LENGTH 42), checked against node-mavlink in
//     tests/firmware/test_radio_signing.cpp.
#pragma once

#include <stdint.h>

#include "quad/link/dialect_pose.h"
#include "quad/link/frame.h"
#include "quad/link/wire.h"

namespace quad {
namespace mavlink {

// docs/hil-protocol.md.
constexpr uint8_t kVehicleSystemId = 1;
constexpr uint8_t kVehicleComponentId = 1;

// X(enumerator, custom_mode number, name): the one list of the flight modes.
#define QUAD_FLIGHT_MODES(X)     \
  X(kDisarmed, 0, "DISARMED")    \
  X(kManual, 1, "MANUAL")        \
  X(kAuto, 2, "AUTO")            \
  X(kLanding, 3, "LANDING")

#define QUAD_FLIGHT_MODE_ENUMERATOR(e, number, name) e = number,
enum class FlightMode : uint8_t { QUAD_FLIGHT_MODES(QUAD_FLIGHT_MODE_ENUMERATOR) };
#undef QUAD_FLIGHT_MODE_ENUMERATOR

#define QUAD_FLIGHT_MODE_COUNT(e, number, name) +1
constexpr int kFlightModeCount = 0 QUAD_FLIGHT_MODES(QUAD_FLIGHT_MODE_COUNT);
#undef QUAD_FLIGHT_MODE_COUNT

// The mode's name (host side; the firmware keeps its copy of the same list in flash: modes.h).
inline const char* flight_mode_name(FlightMode mode) {
#define QUAD_FLIGHT_MODE_NAME(e, number, name) \
  if (mode == FlightMode::e) return name;
  QUAD_FLIGHT_MODES(QUAD_FLIGHT_MODE_NAME)
#undef QUAD_FLIGHT_MODE_NAME
  return "?";
}

// MAV_CMD_COMPONENT_ARM_DISARM param2 that forces a disarm in flight (MAVLink's definition).
constexpr float kForceDisarmMagic = 21196.0f;

// An all-zero key with initial_timestamp 0 turns signing off (MAVLink's definition).
struct SetupSigning {
  static constexpr uint32_t kId = 256;
  static constexpr uint8_t kCrcExtra = 71;
  static constexpr uint8_t kBaseLength = 42;
  static constexpr uint8_t kLength = 42;
  static constexpr const char* kName = "SETUP_SIGNING";
  uint64_t initial_timestamp = 0;  // the signing timestamp to start from (10 us since 2015-01-01)
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  uint8_t secret_key[32] = {};
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.initial_timestamp); io(m.target_system); io(m.target_component); io(m.secret_key);
  }
};
static_assert(wire::count_fields<SetupSigning>().length == SetupSigning::kLength, "SETUP_SIGNING layout");

// The codec's messages plus the dialect's.
inline bool dialect_message_info(uint32_t message_id, MessageInfo* info) {
  switch (message_id) {
    case SetupSigning::kId: *info = message_info<SetupSigning>(); return true;
    case LandingTargetCovariance::kId: *info = message_info<LandingTargetCovariance>(); return true;
    case ExternalPoseTargeted::kId: *info = message_info<ExternalPoseTargeted>(); return true;
    default: return find_message_info(message_id, info);
  }
}

}  // namespace mavlink
}  // namespace quad
