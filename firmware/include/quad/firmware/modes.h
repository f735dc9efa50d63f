// Flight-mode state machine: DISARMED -> MANUAL <-> AUTO -> LANDING -> DISARMED, with arming checks and
// failsafes. It sees the world only through ModeInputs, so every transition is testable on its own.
//
//   DISARMED --arm (estimator converged, sensors healthy, RC present, throttle low)--> MANUAL
//   MANUAL   --auto (fresh vision fix, estimator healthy)--> AUTO
//   AUTO     --manual (RC present)--> MANUAL
//   MANUAL / AUTO --land command--> LANDING
//   LANDING  --manual (RC present: the pilot takes over)--> MANUAL
//   LANDING  --landed--> DISARMED
//   armed    --disarm (landed or throttle low in MANUAL, or forced)--> DISARMED
// Failsafes (checked every iteration while armed):
//   AUTO and vision lost > FS_VIS_TIMEOUT   -> LANDING, level (no horizontal position hold)
//   LANDING and vision lost, above LAND_VIS_HGT -> level (below it the loss is expected: no failsafe)
//   RC lost > FS_RC_TIMEOUT (MANUAL, AUTO)  -> LANDING
//   estimator unhealthy (MANUAL, AUTO)      -> LANDING, level
#pragma once

#include <stdint.h>

#include "quad/firmware/flash.h"
#include "quad/link/dialect.h"

namespace quad {
namespace fw {

// MAVLink custom_mode values (HEARTBEAT.custom_mode, MAV_CMD_DO_SET_MODE param2): the dialect's.
using mavlink::FlightMode;

FlashText mode_name(FlightMode mode);

struct ModeConfig {
  float vision_timeout_s = 0.5f;
  float rc_timeout_s = 1.0f;
  bool rc_required = true;   // false: no RC failsafe and RC not needed to arm (simulator without sticks)
  float arm_throttle_max = 0.1f;  // RC throttle 0..1
};

struct ModeInputs {
  uint32_t now_us = 0;
  bool estimator_converged = false;  // boot calibration finished, filters initialised
  bool estimator_healthy = false;    // attitude and position estimates finite and bounded
  bool sensors_healthy = false;      // IMU samples arriving and plausible
  bool rc_seen = false;              // at least one RC frame received
  uint32_t rc_time_us = 0;           // time of the last RC frame
  float rc_throttle = 0.0f;          // 0..1
  bool vision_seen = false;          // at least one vision fix fused
  uint32_t vision_time_us = 0;       // capture time of the last fused fix
  bool landed = false;               // land detector
  bool below_star_view = false;      // the estimate is below LAND_VIS_HGT: the cameras lose the star
};

enum class Command : uint8_t { kArm, kDisarm, kForceDisarm, kManual, kAuto, kLand };

// The command that selects a mode (MAV_CMD_DO_SET_MODE).
inline Command command_for(FlightMode mode) {
  switch (mode) {
    case FlightMode::kDisarmed: return Command::kDisarm;
    case FlightMode::kManual: return Command::kManual;
    case FlightMode::kAuto: return Command::kAuto;
    case FlightMode::kLanding: return Command::kLand;
  }
  return Command::kDisarm;
}

// Why the machine changed mode or refused a command; each has a STATUSTEXT (reason_text()).
enum class Reason : uint8_t {
  kNone,
  kArmed,
  kDisarmed,
  kLandedDisarmed,
  kManualSelected,
  kAutoSelected,
  kLandCommanded,
  kFailsafeVisionLost,
  kFailsafeRcLost,
  kFailsafeEstimator,
  kRejectEstimatorNotConverged,
  kRejectSensors,
  kRejectNoRc,
  kRejectThrottleHigh,
  kRejectNoVision,
  kRejectEstimatorUnhealthy,
  kRejectNotArmed,
  kRejectAlreadyArmed,
  kRejectInFlight,
  kRejectLanding,
};

FlashText reason_text(Reason reason);

struct Transition {
  bool changed = false;    // the mode changed
  bool accepted = true;    // for commands: accepted (a no-op command is accepted, unchanged)
  FlightMode from = FlightMode::kDisarmed;
  FlightMode to = FlightMode::kDisarmed;
  Reason reason = Reason::kNone;
};

class ModeMachine {
 public:
  // The default ModeConfig's values (the in-class initialisers below are what configure() makes of it).
  ModeMachine() = default;
  explicit ModeMachine(const ModeConfig& config) { configure(config); }

  void configure(const ModeConfig& config);

  FlightMode mode() const { return mode_; }
  bool armed() const { return mode_ != FlightMode::kDisarmed; }
  // True in a LANDING entered without a trustworthy position: hold the vehicle level, do not chase
  // a horizontal position.
  bool land_level() const { return land_level_; }

  // A command from the ground station (or the RC switches).
  Transition command(Command cmd, const ModeInputs& in);

  // Failsafes and automatic transitions; call once per control iteration.
  Transition update(const ModeInputs& in);

  bool vision_fresh(const ModeInputs& in) const;
  bool rc_fresh(const ModeInputs& in) const;

 private:
  Transition go(FlightMode to, Reason reason, bool level = false);
  static Transition refuse(FlightMode mode, Reason reason);
  Transition unchanged() const;  // a no-op command: accepted, mode kept

  // The timeouts as the largest age in microseconds that is still fresh: an age passes exactly when
  // static_cast<float>(age_us) <= timeout_s * 1e6f (integers on the hot path: no float compare, no
  // conversion of the age; modes.cpp max_age_us()).
  int32_t vision_max_age_us_ = 500000;  // ModeConfig().vision_timeout_s = 0.5 s
  int32_t rc_max_age_us_ = 1000000;     // ModeConfig().rc_timeout_s = 1 s
  bool rc_required_ = true;
  float arm_throttle_max_ = 0.1f;
  FlightMode mode_ = FlightMode::kDisarmed;
  bool land_level_ = false;
};

}  // namespace fw
}  // namespace quad
