#include "quad/firmware/modes.h"

namespace quad {
namespace fw {
namespace {

constexpr int32_t kMaxInt32 = 2147483647;

// The largest age (us) that static_cast<float>(age) <= timeout_s * 1e6f admits, 0 when no positive age
// does. The conversion of an int32 to float is monotonic, so the ages that pass are exactly those up to
// this one.
__attribute__((noinline)) int32_t max_age_us(float timeout_s) {
  const float t = timeout_s * 1e6f;
  if (!(t >= 1.0f)) return 0;                    // NaN, negative, below a microsecond
  if (t >= 2147483648.0f) return kMaxInt32;      // every int32 age converts to at most 2^31
  int32_t a = static_cast<int32_t>(t);           // floor: float(a) <= t
  // Above 2^24 neighbouring ints share a float: take every one that still converts to at most t (below
  // t + 64 for t < 2^31: no overflow).
  while (static_cast<float>(a + 1) <= t) ++a;
  return a;
}

// True when `then_us` is at most the timeout before `now_us`, robust to the 32-bit microsecond clock
// wrapping: age_us <= 0 || static_cast<float>(age_us) <= timeout_s * 1e6f, on integers (max_age_us()).
bool within(uint32_t now_us, uint32_t then_us, int32_t max_age_us) {
  return static_cast<int32_t>(now_us - then_us) <= max_age_us;
}

}  // namespace

FlashText mode_name(FlightMode mode) {
  switch (mode) {
#define QUAD_FLIGHT_MODE_TEXT(e, number, name) \
  case FlightMode::e:                           \
    return QUAD_TEXT(name);
    QUAD_FLIGHT_MODES(QUAD_FLIGHT_MODE_TEXT)
#undef QUAD_FLIGHT_MODE_TEXT
  }
  return QUAD_TEXT("?");
}

FlashText reason_text(Reason reason) {
  switch (reason) {
    case Reason::kNone: return QUAD_TEXT("");
    case Reason::kArmed: return QUAD_TEXT("armed");
    case Reason::kDisarmed: return QUAD_TEXT("disarmed");
    case Reason::kLandedDisarmed: return QUAD_TEXT("landed, disarmed");
    case Reason::kManualSelected: return QUAD_TEXT("manual selected");
    case Reason::kAutoSelected: return QUAD_TEXT("auto selected");
    case Reason::kLandCommanded: return QUAD_TEXT("land commanded");
    case Reason::kFailsafeVisionLost: return QUAD_TEXT("FAILSAFE vision lost: level, land");
    case Reason::kFailsafeRcLost: return QUAD_TEXT("FAILSAFE RC lost: land");
    case Reason::kFailsafeEstimator: return QUAD_TEXT("FAILSAFE estimator unhealthy: land");
    case Reason::kRejectEstimatorNotConverged: return QUAD_TEXT("PREFLIGHT: estimator not converged");
    case Reason::kRejectSensors: return QUAD_TEXT("arm refused: sensors unhealthy");
    case Reason::kRejectNoRc: return QUAD_TEXT("refused: no RC");
    case Reason::kRejectThrottleHigh: return QUAD_TEXT("arm refused: throttle not low");
    case Reason::kRejectNoVision: return QUAD_TEXT("auto refused: no vision fix");
    case Reason::kRejectEstimatorUnhealthy: return QUAD_TEXT("auto refused: estimator unhealthy");
    case Reason::kRejectNotArmed: return QUAD_TEXT("refused: not armed");
    case Reason::kRejectAlreadyArmed: return QUAD_TEXT("arm refused: already armed");
    case Reason::kRejectInFlight: return QUAD_TEXT("disarm refused: in flight");
    case Reason::kRejectLanding: return QUAD_TEXT("refused: landing");
  }
  return QUAD_TEXT("?");
}

void ModeMachine::configure(const ModeConfig& config) {
  vision_max_age_us_ = max_age_us(config.vision_timeout_s);
  rc_max_age_us_ = max_age_us(config.rc_timeout_s);
  rc_required_ = config.rc_required;
  arm_throttle_max_ = config.arm_throttle_max;
}

bool ModeMachine::vision_fresh(const ModeInputs& in) const {
  return in.vision_seen && within(in.now_us, in.vision_time_us, vision_max_age_us_);
}

bool ModeMachine::rc_fresh(const ModeInputs& in) const {
  return in.rc_seen && within(in.now_us, in.rc_time_us, rc_max_age_us_);
}

Transition ModeMachine::go(FlightMode to, Reason reason, bool level) {
  Transition t;
  t.changed = to != mode_;
  t.from = mode_;
  t.to = to;
  t.reason = reason;
  mode_ = to;
  land_level_ = to == FlightMode::kLanding && level;
  return t;
}

Transition ModeMachine::unchanged() const { return Transition{false, true, mode_, mode_, Reason::kNone}; }

Transition ModeMachine::refuse(FlightMode mode, Reason reason) {
  Transition t;
  t.accepted = false;
  t.from = t.to = mode;
  t.reason = reason;
  return t;
}

Transition ModeMachine::command(Command cmd, const ModeInputs& in) {
  const bool rc_ok = !rc_required_ || rc_fresh(in);
  switch (cmd) {
    case Command::kArm:
      if (armed()) return refuse(mode_, Reason::kRejectAlreadyArmed);
      if (!in.estimator_converged) return refuse(mode_, Reason::kRejectEstimatorNotConverged);
      if (!in.sensors_healthy) return refuse(mode_, Reason::kRejectSensors);
      if (!rc_ok) return refuse(mode_, Reason::kRejectNoRc);
      if (rc_fresh(in) && in.rc_throttle > arm_throttle_max_) return refuse(mode_, Reason::kRejectThrottleHigh);
      return go(FlightMode::kManual, Reason::kArmed);

    case Command::kDisarm: {
      if (!armed()) return Transition{};
      const bool throttle_low = mode_ == FlightMode::kManual && rc_fresh(in) && in.rc_throttle <= arm_throttle_max_;
      if (!in.landed && !throttle_low) return refuse(mode_, Reason::kRejectInFlight);
      return go(FlightMode::kDisarmed, Reason::kDisarmed);
    }

    case Command::kForceDisarm:
      if (!armed()) return Transition{};
      return go(FlightMode::kDisarmed, Reason::kDisarmed);

    case Command::kManual:
      if (!armed()) return refuse(mode_, Reason::kRejectNotArmed);
      if (mode_ == FlightMode::kManual) return unchanged();
      if (!rc_fresh(in)) return refuse(mode_, Reason::kRejectNoRc);
      return go(FlightMode::kManual, Reason::kManualSelected);

    case Command::kAuto:
      if (!armed()) return refuse(mode_, Reason::kRejectNotArmed);
      if (mode_ == FlightMode::kAuto) return unchanged();
      if (mode_ == FlightMode::kLanding) return refuse(mode_, Reason::kRejectLanding);
      if (!in.estimator_healthy) return refuse(mode_, Reason::kRejectEstimatorUnhealthy);
      if (!vision_fresh(in)) return refuse(mode_, Reason::kRejectNoVision);
      return go(FlightMode::kAuto, Reason::kAutoSelected);

    case Command::kLand:
      if (!armed()) return refuse(mode_, Reason::kRejectNotArmed);
      if (mode_ == FlightMode::kLanding) return unchanged();
      // Without a fresh fix there is no horizontal position to hold: land level.
      return go(FlightMode::kLanding, Reason::kLandCommanded, !vision_fresh(in));
  }
  return Transition{};
}

Transition ModeMachine::update(const ModeInputs& in) {
  switch (mode_) {
    case FlightMode::kDisarmed:
      return Transition{};
    case FlightMode::kManual:
    case FlightMode::kAuto:
      if (!in.estimator_healthy) return go(FlightMode::kLanding, Reason::kFailsafeEstimator, true);
      if (rc_required_ && !rc_fresh(in)) {
        return go(FlightMode::kLanding, Reason::kFailsafeRcLost, mode_ != FlightMode::kAuto || !vision_fresh(in));
      }
      if (mode_ == FlightMode::kAuto && !vision_fresh(in)) {
        return go(FlightMode::kLanding, Reason::kFailsafeVisionLost, true);
      }
      return Transition{};
    case FlightMode::kLanding:
      if (in.landed) return go(FlightMode::kDisarmed, Reason::kLandedDisarmed);
      // A landing that holds position falls back to level once the fix or the estimator is gone, and
      // stays level for the rest of the descent. Below LAND_VIS_HGT the cameras see only a patch of the
      // star: its loss there is the landing's, not a fault, and the estimate holds the position down.
      if (!land_level_ && (!in.estimator_healthy || (!vision_fresh(in) && !in.below_star_view))) {
        land_level_ = true;
        return Transition{false, true, mode_, mode_,
                          in.estimator_healthy ? Reason::kFailsafeVisionLost : Reason::kFailsafeEstimator};
      }
      return Transition{};
  }
  return Transition{};
}

}  // namespace fw
}  // namespace quad
