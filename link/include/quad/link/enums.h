// The MAVLink enumeration values this system uses (values from the MAVLink common/minimal dialects).
#pragma once

#include <stdint.h>

namespace quad {
namespace mavlink {

// Component ids (MAV_COMPONENT) and system ids of this system, see docs/hil-protocol.md.
constexpr uint8_t kCompIdAll = 0;
constexpr uint8_t kCompIdAutopilot1 = 1;
constexpr uint8_t kCompIdMissionPlanner = 190;
constexpr uint8_t kCompIdVisualInertialOdometry = 197;

// MAV_TYPE, MAV_AUTOPILOT
constexpr uint8_t kMavTypeQuadrotor = 2;
constexpr uint8_t kMavTypeGcs = 6;
constexpr uint8_t kMavAutopilotGeneric = 0;
constexpr uint8_t kMavAutopilotInvalid = 8;

// MAV_MODE_FLAG (HEARTBEAT.base_mode, HIL_ACTUATOR_CONTROLS.mode)
constexpr uint8_t kModeFlagCustomModeEnabled = 1;
constexpr uint8_t kModeFlagHilEnabled = 32;
constexpr uint8_t kModeFlagSafetyArmed = 128;

// MAV_STATE (HEARTBEAT.system_status)
constexpr uint8_t kStateUninit = 0;
constexpr uint8_t kStateBoot = 1;
constexpr uint8_t kStateCalibrating = 2;
constexpr uint8_t kStateStandby = 3;
constexpr uint8_t kStateActive = 4;
constexpr uint8_t kStateCritical = 5;
constexpr uint8_t kStateEmergency = 6;

// MAV_VTOL_STATE and MAV_LANDED_STATE (EXTENDED_SYS_STATE).
constexpr uint8_t kVtolStateUndefined = 0;  // not a VTOL
constexpr uint8_t kLandedStateUndefined = 0;
constexpr uint8_t kLandedStateOnGround = 1;
constexpr uint8_t kLandedStateInAir = 2;
constexpr uint8_t kLandedStateTakeoff = 3;
constexpr uint8_t kLandedStateLanding = 4;

// ESTIMATOR_STATUS_FLAGS (ESTIMATOR_STATUS.flags)
constexpr uint16_t kEstimatorAttitude = 1;
constexpr uint16_t kEstimatorVelocityHoriz = 2;
constexpr uint16_t kEstimatorVelocityVert = 4;
constexpr uint16_t kEstimatorPosHorizRel = 8;
constexpr uint16_t kEstimatorPosHorizAbs = 16;
constexpr uint16_t kEstimatorPosVertAbs = 32;
constexpr uint16_t kEstimatorPosVertAgl = 64;
constexpr uint16_t kEstimatorConstPosMode = 128;
constexpr uint16_t kEstimatorPredPosHorizRel = 256;
constexpr uint16_t kEstimatorPredPosHorizAbs = 512;
constexpr uint16_t kEstimatorGpsGlitch = 1024;
constexpr uint16_t kEstimatorAccelError = 2048;

// MAV_CMD (COMMAND_LONG.command)
constexpr uint16_t kCmdNavLand = 21;
constexpr uint16_t kCmdDoSetMode = 176;
constexpr uint16_t kCmdComponentArmDisarm = 400;

// MAV_RESULT (COMMAND_ACK.result)
constexpr uint8_t kResultAccepted = 0;
constexpr uint8_t kResultTemporarilyRejected = 1;
constexpr uint8_t kResultDenied = 2;
constexpr uint8_t kResultUnsupported = 3;
constexpr uint8_t kResultFailed = 4;

// MAV_SEVERITY (STATUSTEXT.severity)
constexpr uint8_t kSeverityEmergency = 0;
constexpr uint8_t kSeverityAlert = 1;
constexpr uint8_t kSeverityCritical = 2;
constexpr uint8_t kSeverityError = 3;
constexpr uint8_t kSeverityWarning = 4;
constexpr uint8_t kSeverityNotice = 5;
constexpr uint8_t kSeverityInfo = 6;
constexpr uint8_t kSeverityDebug = 7;

// MAV_FRAME
constexpr uint8_t kFrameLocalNed = 1;
constexpr uint8_t kFrameBodyFrd = 12;

// MAV_PARAM_TYPE
constexpr uint8_t kParamTypeReal32 = 9;

// HIL_ACTUATOR_CONTROLS_FLAGS
constexpr uint64_t kHilActuatorControlsFlagLockstep = 1;

}  // namespace mavlink
}  // namespace quad
