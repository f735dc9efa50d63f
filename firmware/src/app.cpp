#include "quad/firmware/app.h"

#include <string.h>

#include "quad/firmware/app_checks.h"
#include "quad/firmware/param_fields.h"
#include "quad/firmware/setup_signing.h"
#include "quad/math/float_bits.h"

namespace quad {
namespace fw {
namespace mav = ::quad::mavlink;

namespace {

// MAV_SYS_STATUS_SENSOR bits reported in SYS_STATUS.
constexpr uint32_t kSensorGyro = UINT32_C(1) << 0;
constexpr uint32_t kSensorAccel = UINT32_C(1) << 1;
constexpr uint32_t kSensorMag = UINT32_C(1) << 2;
constexpr uint32_t kSensorVision = UINT32_C(1) << 7;
constexpr uint32_t kSensorRc = UINT32_C(1) << 16;
constexpr uint32_t kSensorAhrs = UINT32_C(1) << 21;

// HIL_SENSOR.fields_updated: bits 6..8 flag a new magnetometer sample.
constexpr uint32_t kHilMagFields = 0x1C0u;

// SET_POSITION_TARGET_LOCAL_NED.type_mask bits.
constexpr uint16_t kIgnorePosition = 0x7u;
constexpr uint16_t kIgnoreYaw = 0x400u;

// Fixes refused in a row before the one taken that make the jump worth a STATUSTEXT (one lost outlier
// is routine; 3 at 30 Hz is 0.1 s of a fix that disagrees with the estimate).
constexpr uint8_t kJumpReportRejections = 3;
// Frames in a row whose frame-rate work may give its iteration to a vision fix's step: a gate and an
// update (FlightApp::step).
constexpr uint8_t kMaxFrameWorkDeferred = 2;

float yaw_of(const Quat& q) { return to_euler(q).yaw; }

// A counter in a 16-bit SYS_STATUS field: saturated (one out-of-line copy, not five inline).
__attribute__((noinline)) uint16_t saturate16(uint32_t n) { return static_cast<uint16_t>(n > UINT16_MAX ? UINT16_MAX : n); }

// |det W| below this is not a calibration but a broken matrix (a fitted W is near a rotation-free scale).
constexpr float kMinSoftIronDeterminant = 0.05f;

// The Earth field with magnetic north along x, expressed in true NED: turned about down by the
// declination (east positive).
// (Out of line: two callers, and two inlined copies of sinf, cosf and six products cost AVR flash.)
__attribute__((noinline)) Vec3 decline(const Vec3& magnetic, float declination) {
  const float c = cosf(declination), s = sinf(declination);
  return Vec3{c * magnetic.x - s * magnetic.y, s * magnetic.x + c * magnetic.y, magnetic.z};
}

// MANUAL_CONTROL axis (-1000..1000) to a 1000..2000 us pulse.
uint16_t axis_to_pulse(int16_t v, bool reverse) {
  const int32_t axis = reverse ? -static_cast<int32_t>(v) : static_cast<int32_t>(v);
  int32_t p = 1500 + axis / 2;
  if (p < 1000) p = 1000;
  if (p > 2000) p = 2000;
  return static_cast<uint16_t>(p);
}

void copy_name(char (&dst)[16], const char* src) {
  memset(dst, 0, sizeof dst);
  for (uint8_t i = 0; i < 16 && src[i] != '\0'; ++i) dst[i] = src[i];
}

// One STATUSTEXT line assembled from flash texts and RAM strings (names, the control library's field
// names); anything beyond MAVLink's 50 characters is cut.
// (Out of line: one copy of each part, not one per line assembled.)
class StatusLine {
 public:
  __attribute__((noinline)) explicit StatusLine(uint8_t severity) { msg_.severity = severity; }
  __attribute__((noinline)) StatusLine& operator<<(FlashText text) {
    append_text(msg_.text, sizeof msg_.text, n_, text);
    return *this;
  }
  __attribute__((noinline)) StatusLine& operator<<(const char* ram) {
    for (const char* c = ram; c != nullptr && *c != '\0' && n_ < sizeof msg_.text; ++c) msg_.text[n_++] = *c;
    return *this;
  }
  const mav::Statustext& message() const { return msg_; }

 private:
  mav::Statustext msg_;
  size_t n_ = 0;
};

// Decimal text of an unsigned number, for STATUSTEXT lines (no printf on the freestanding targets).
class Decimal {
 public:
  explicit Decimal(uint32_t value) {
    char reversed[10];
    uint8_t n = 0;
    do {
      reversed[n++] = static_cast<char>('0' + value % 10u);
      value /= 10u;
    } while (value != 0u);
    for (uint8_t i = 0; i < n; ++i) text_[i] = reversed[n - 1 - i];
    text_[n] = '\0';
  }
  const char* c_str() const { return text_; }

 private:
  char text_[11];
};

FlashText rejection_text(est::CalibrationStatus status) {
  switch (status) {
    case est::CalibrationStatus::Moved: return QUAD_TEXT("calibration: vehicle moved, again");
    case est::CalibrationStatus::Turning: return QUAD_TEXT("calibration: vehicle turning, again");
    case est::CalibrationStatus::NotLevel: return QUAD_TEXT("calibration: not level, again");
    case est::CalibrationStatus::NonFinite: return QUAD_TEXT("calibration: bad sample, again");
    default: return QUAD_TEXT("calibration: again");
  }
}

}  // namespace

__attribute__((noinline)) void load_fields(const Params& p, void* dst, const ParamField* table, uint8_t n) {
  uint8_t* const base = static_cast<uint8_t*>(dst);
  for (uint8_t i = 0; i < n; ++i) {
    ParamField f;
    flash_copy(&f, &table[i], sizeof f);
    const float v = p.get(f.id);
    memcpy(base + f.offset, &v, sizeof v);
  }
}

AppCounters::AppCounters() { memset(static_cast<void*>(this), 0, sizeof *this); }

FlightApp::FlightApp()
    : senders_{mav::Sender(kVehicleSystemId, kVehicleComponentId), mav::Sender(kVehicleSystemId, kVehicleComponentId)} {}

void FlightApp::init(const AppIo& io, bool hil) {
  io_ = io;
  hil_ = hil;
  store_status_ = params_load(io_.storage, params_);
  const bool key_ok = radio_.load(io_.storage);
  const char* error = nullptr;
  if (!apply_params(params_, &error)) {
    // Values that pass their ranges but not a component's own checks (a combination): defaults.
    params_.reset_to_defaults();
    apply_params(params_, &error);
    send_statustext((StatusLine(mav::kSeverityError) << QUAD_TEXT("params rejected, defaults: ") << error).message());
  }
  if (store_status_ != StoreStatus::kLoaded) send_statustext(mav::kSeverityWarning, store_status_text(store_status_));
  if (!key_ok) send_statustext(mav::kSeverityError, QUAD_TEXT("signing: key store corrupt, no key"));
  if (radio_.enabled() && !radio_.has_key()) send_statustext(mav::kSeverityError, QUAD_TEXT("signing: no key, radio closed"));
  calibration_.restart();
  send_statustext(mav::kSeverityInfo, QUAD_TEXT("calibrating: keep the vehicle still"));
}

bool FlightApp::apply_params(const Params& p, const char** error) {
  // The float fields that take a parameter unchanged come from the tables of param_fields.h; the rest here.
  ctrl::CascadeParams cp;
  load_fields(p, cp, kCascadeFields);
  cp.vehicle.frame = p.get(kVehFrame) >= 0.5f ? ctrl::Frame::kX : ctrl::Frame::kPlus;
  cp.vehicle.yaw_coeff = p.get(kVehYawK) * p.get(kVehThrCoef);

  ctrl::ManualParams mp;
  load_fields(p, mp, kManualFields);
  mp.max_thrust = p.get(kManThrMax) * cp.vehicle.max_total_thrust();
  mp.dead_band = static_cast<uint16_t>(p.get(kManDeadband));

  ctrl::ShaperParams sp;
  load_fields(p, sp, kShaperFields);

  est::MagCalibration mag_cal;
  load_fields(p, mag_cal, kMagFields);

  const char* bad = ctrl::validate(mp);
  if (bad == nullptr) bad = ctrl::validate(sp);
  // A (nearly) singular soft-iron matrix would flatten the field onto a line or a plane: no heading.
  if (bad == nullptr && absf(determinant(mag_cal.soft_iron)) < kMinSoftIronDeterminant) bad = "MAG_SI (singular)";
  if (bad == nullptr) {
    // Cascade::configure() keeps the old parameters when it refuses the new ones.
    const ctrl::ParamError e = cascade_.configure(cp);
    if (!e.ok()) bad = e.field;
  }
  if (bad != nullptr) {
    *error = bad;
    return false;
  }
  manual_.set_params(mp);
  shaper_.set_params(sp);

  est::ObserverParams op;
  load_fields(p, op, kObserverFields);
  // The Earth field is learned from the boot calibration (magnetic north as x), then turned by the
  // declination so the heading is relative to true north; a new MAG_DECL turns it again.
  op.mag_ref_from_init = !mag_ref_learned_;
  if (mag_ref_learned_) op.mag_ref_ned = decline(mag_ref_magnetic_, p.get(kMagDecl));
  observer_.set_params(op);
  mag_cal_ = mag_cal;
  mag_cal_identity_ = identity_calibration(p);

  est::PositionFilterParams fp;
  fp.process_noise = p.get(kKfQModel) >= 0.5f ? est::ProcessNoise::WhiteAcceleration : est::ProcessNoise::ThesisDiagonal;
  load_fields(p, fp, kFilterFields);
  fp.z_accel_bias = p.get(kKfZBias) >= 0.5f;
  fp.xy_accel_bias = p.get(kKfXYBias) >= 0.5f;
  filter_.set_params(fp);

  load_fields(p, star_ned_, kStarFields);

  // Every field given (no default-initialised ModeConfig to copy from RAM on the AVR).
  const ModeConfig mc{p.get(kFsVisTimeout), p.get(kFsRcTimeout), p.get(kFsRcEnable) >= 0.5f, p.get(kArmThrMax)};
  modes_.configure(mc);
  rc_switches_enabled_ = p.get(kRcSwitches) >= 0.5f;
  radio_.set_enabled(p.get(kSignEnable) >= 0.5f);

  CalibrationConfig cc;
  load_fields(p, cc, kCalibrationFields);
  calibration_.configure(cc);
  imu_clip_.configure(p.get(kImuGyroRange), p.get(kImuAccRange), p.get(kImuClipHold));

  const float loop_hz = p.get(kLoopHz);
  loop_timer_.set_rate_hz(loop_hz);
  stages_.configure(kPositionRateHz, loop_hz);
  // One telemetry stream per iteration at the default rates (scheduler.h: an iteration that sent all
  // four took 45 000 more cycles on the AVR than one that sent none).
  heartbeat_rate_.configure(p.get(kTelHbHz), loop_hz, 1);
  attitude_rate_.configure(p.get(kTelAttHz), loop_hz, 0);
  position_tel_rate_.configure(p.get(kTelPosHz), loop_hz, 5);
  status_rate_.configure(p.get(kTelSysHz), loop_hz, 3);
  // The attitude history reaches back 0.3 s at any loop rate, beyond the position filter's 0.25 s.
  history_.set_decimation(AttitudeHistory::decimation_for(loop_hz, 0.3f));

  trim_.configure(p.get(kPosKiXY), p.get(kPosIMaxXY), p.get(kPosKiZ), p.get(kPosIMaxZ));
  accel_bias_.configure(p.get(kEstABiasTau), p.get(kEstABiasMax));
  // LAND_SPEED, LAND_VZ_MAX and LAND_TIME are read from params_ where used (they are the values
  // applied here: params_ takes the candidate once this returns true).
  land_thrust_max_ = p.get(kLandThrFrac) * cp.vehicle.hover_thrust();
  return true;
}

const char* FlightApp::override_param(uint8_t index, float value) {
  Params candidate = params_;
  switch (candidate.set(index, value)) {
    case ParamError::kNone: break;
    case ParamError::kUnknownName: return "no such parameter";
    case ParamError::kNotFinite: return "not a finite number";
    case ParamError::kOutOfRange: return "outside the parameter's range";
  }
  const char* error = nullptr;
  if (!apply_params(candidate, &error)) return error;
  params_ = candidate;
  return nullptr;
}

// ---------------------------------------------------------------------------------------------------
// Receiving

void FlightApp::receive(uint8_t port, const uint8_t* data, uint16_t length, uint32_t now_us) {
  if (port >= hal::kPortCount) return;
  if (!hil_) now_us_ = now_us;
  parsers_[port].feed(data, length, [this, port](const mav::Frame& frame) {
    // The radio is where strangers can talk: its frames pass the signature check first (counted).
    if (port == hal::kUart2 && !mav::accepted(radio_.check(frame))) return;
    on_frame(port, frame);
  });
}

void FlightApp::on_frame(uint8_t port, const mav::Frame& frame) {
  switch (frame.message_id) {
    case mav::HilSensor::kId: {
      mav::HilSensor msg;
      if (hil_ && mav::decode(frame, msg)) on_hil_sensor(msg);
      break;
    }
    case mav::CommandLong::kId: {
      mav::CommandLong msg;
      if (mav::decode(frame, msg)) on_command(port, msg);
      break;
    }
    case mav::ManualControl::kId: {
      mav::ManualControl msg;
      if (mav::decode(frame, msg)) on_manual_control(msg);
      break;
    }
    case mav::SetPositionTargetLocalNed::kId: {
      mav::SetPositionTargetLocalNed msg;
      if (mav::decode(frame, msg) && (msg.target_system == kVehicleSystemId || msg.target_system == 0)) on_setpoint(msg);
      break;
    }
    case mav::LandingTarget::kId: {
      mav::LandingTarget msg;
      if (!mav::decode(frame, msg)) break;
      ++counters_.fixes_received;
      if (msg.frame != mav::kFrameBodyFrd || msg.position_valid != 1) {
        ++counters_.fixes_invalid;
        break;
      }
      const uint32_t capture_us = static_cast<uint32_t>(msg.time_usec);
      Quat q_capture;
      if (!history_.lookup(capture_us, q_capture)) {
        ++counters_.fixes_rejected;
        break;
      }
      // thesis eq. 8.5 with the errata sign, the attitude taken at the capture time.
      on_fix(vehicle_position_from_star(star_ned_, q_capture, Vec3{msg.x, msg.y, msg.z}), capture_us);
      break;
    }
    case mav::VisionPositionEstimate::kId: {
      mav::VisionPositionEstimate msg;
      if (!mav::decode(frame, msg)) break;
      ++counters_.fixes_received;
      on_fix(Vec3{msg.x, msg.y, msg.z}, static_cast<uint32_t>(msg.usec));
      break;
    }
    case mav::ParamRequestList::kId: {
      mav::ParamRequestList msg;
      if (mav::decode(frame, msg) && (msg.target_system == kVehicleSystemId || msg.target_system == 0)) {
        param_stream_next_ = 0;
        param_stream_port_ = port;
      }
      break;
    }
    case mav::ParamRequestRead::kId: {
      mav::ParamRequestRead msg;
      if (mav::decode(frame, msg) && (msg.target_system == kVehicleSystemId || msg.target_system == 0)) {
        on_param_read(port, msg);
      }
      break;
    }
    case mav::ParamSet::kId: {
      mav::ParamSet msg;
      if (mav::decode(frame, msg) && (msg.target_system == kVehicleSystemId || msg.target_system == 0)) {
        on_param_set(port, msg);
      }
      break;
    }
    case mav::Timesync::kId: {
      mav::Timesync msg;
      if (mav::decode(frame, msg)) on_timesync(port, msg);
      break;
    }
    case SetupSigning::kId: {
      SetupSigning msg;
      if (mav::decode(frame, msg) && (msg.target_system == kVehicleSystemId || msg.target_system == 0)) {
        on_setup_signing(port, msg);
      }
      break;
    }
    default:
      break;
  }
}

void FlightApp::on_hil_sensor(const mav::HilSensor& msg) {
  ++counters_.hil_sensor_frames;
  if (clock_started_ && msg.time_usec == hil_time_usec_) {
    // The simulator repeated a step whose answer it missed: answer again, do not step twice.
    send_actuators(msg.time_usec);
    return;
  }
  hil_time_usec_ = msg.time_usec;
  hal::ImuSample imu;
  imu.accel = Vec3{msg.xacc, msg.yacc, msg.zacc};
  imu.gyro = Vec3{msg.xgyro, msg.ygyro, msg.zgyro};
  hal::MagSample mag;
  mag.field = Vec3{msg.xmag, msg.ymag, msg.zmag};
  const bool mag_new = (msg.fields_updated & kHilMagFields) != 0;
  step(static_cast<uint32_t>(msg.time_usec), imu, mag_new ? &mag : nullptr);
  send_actuators(msg.time_usec);
}

template <class Step>
void FlightApp::fix_step(Step step) {
  const uint32_t resets_before = filter_.health().resets;
  mark(hal::TracePoint::kFixBegin);
  const est::FixResult r = step();
  mark(hal::TracePoint::kFixEnd);
  if (r != est::FixResult::Pending) fix_result(r, filter_.health().resets != resets_before);
}

void FlightApp::on_fix(const Vec3& p_ned, uint32_t capture_us) {
  if (!is_finite(p_ned)) {
    ++counters_.fixes_invalid;
    return;
  }
  if (stages_.per_frame() >= kStageCount || filter_.fix_in_progress()) {
    // With four or more iterations per frame (400 Hz) no iteration has room for the whole fusion beside
    // its stage: it waits for the frame-rate work's iteration, which has no other stage, and takes its
    // gate in one frame and its update in the next (FlightApp::step). With fewer, the frame-rate work
    // shares its iteration with another stage, and the fix is fused where it arrives, as at 100 Hz.
    const est::FixResult r = filter_.queue_fix(p_ned, capture_us);
    if (r != est::FixResult::Pending) fix_result(r, false);
    return;
  }
  fix_step([&] { return filter_.fuse_position(p_ned, capture_us); });
}


void FlightApp::fix_result(est::FixResult r, bool reset) {
  const bool taken = r == est::FixResult::Fused || r == est::FixResult::Initialized;
  if (taken && (reset || fixes_rejected_in_a_row_ >= kJumpReportRejections)) {
    // The estimate jumped to a fix it had refused before (a decoy taken for the star, a moved marker,
    // a return from a long outage): not a failsafe, but the operator must hear of it.
    const Decimal n(fixes_rejected_in_a_row_);
    send_statustext((StatusLine(mav::kSeverityWarning) << QUAD_TEXT("position jumped to the fix after ") << n.c_str()
                     << QUAD_TEXT(" rejected"))
                        .message());
  }
  if (taken) {
    ++counters_.fixes_fused;
    fixes_rejected_in_a_row_ = 0;
    // Freshness counts from when the fix is taken on the vehicle clock (its arrival; at 400 Hz a few
    // frames later): a fix delayed by the link is still news.
    vision_seen_ = true;
    vision_time_us_ = now_us_;
  } else {
    ++counters_.fixes_rejected;
    // (One refused because another was still in progress says nothing about the star.)
    if (r != est::FixResult::RejectedBusy && fixes_rejected_in_a_row_ < 255) ++fixes_rejected_in_a_row_;
  }
}

void FlightApp::on_manual_control(const mav::ManualControl& msg) {
  // docs/hil-protocol.md: x pitch (forward +), y roll (right +), z throttle 0..1000, r yaw (right +).
  // A forward stick is a pulse below 1500 on the pitch channel (nose down, control/manual.h).
  ctrl::RcSticks sticks;
  sticks.roll = axis_to_pulse(msg.y, false);
  sticks.pitch = axis_to_pulse(msg.x, true);
  sticks.yaw = axis_to_pulse(msg.r, false);
  const int32_t throttle = 1000 + (msg.z < 0 ? 0 : static_cast<int32_t>(msg.z));
  sticks.throttle = static_cast<uint16_t>(throttle > 2000 ? 2000 : throttle);
  // Buttons bit 0: motor-enable switch, bit 1: manual/auto switch (used with RC_SWITCHES only).
  RcSwitches sw;
  sw.motors_enabled = (msg.buttons & 0x1u) != 0;
  sw.auto_mode = (msg.buttons & 0x2u) != 0;
  rc_input(sticks, now_us_, &sw);
}

void FlightApp::rc_input(const ctrl::RcSticks& sticks, uint32_t t_us, const RcSwitches* switches) {
  sticks_ = sticks;
  rc_seen_ = true;
  rc_time_us_ = t_us;
  if (!rc_switches_enabled_ || switches == nullptr) return;
  // Transitions only: a transmitter switched on with "motors enabled" does not arm the vehicle.
  const RcSwitches before = switches_;
  switches_ = *switches;
  if (!switches_known_) {
    switches_known_ = true;
    return;
  }
  if (switches->motors_enabled != before.motors_enabled) {
    handle_transition(modes_.command(switches->motors_enabled ? Command::kArm : Command::kForceDisarm, mode_inputs()));
  }
  if (switches->auto_mode != before.auto_mode && modes_.armed()) {
    handle_transition(modes_.command(switches->auto_mode ? Command::kAuto : Command::kManual, mode_inputs()));
  }
}

void FlightApp::on_setpoint(const mav::SetPositionTargetLocalNed& msg) {
  if (msg.coordinate_frame != mav::kFrameLocalNed || (msg.type_mask & kIgnorePosition) != 0) return;
  const Vec3 target{msg.x, msg.y, msg.z};
  if (!is_finite(target)) return;
  shaper_.set_target(target);
  if ((msg.type_mask & kIgnoreYaw) == 0 && is_finite(msg.yaw)) setpoint_.yaw_d = wrap_pi(msg.yaw);
}

void FlightApp::on_timesync(uint8_t port, const mav::Timesync& msg) {
  if (msg.tc1 != 0) return;  // an answer to someone else's request
  // TIMESYNC answer: our clock in tc1 (ns), the request's ts1 echoed, so the peer can map its capture
  // times onto the vehicle clock.
  mav::Timesync reply;
  reply.tc1 = static_cast<int64_t>(hil_ ? hil_time_usec_ : now_us_) * 1000;
  reply.ts1 = msg.ts1;
  send(port, reply);
}

void FlightApp::on_setup_signing(uint8_t port, const SetupSigning& msg) {
  if (port != hal::kUart0) {
    // Keys are provisioned over the USB cable only, even by someone who holds the current key.
    radio_.refuse_provisioning();
    send_statustext(mav::kSeverityWarning, QUAD_TEXT("signing: key refused on radio"));
    return;
  }
  switch (radio_.provision(io_.storage, msg)) {
    case RadioSigning::Provisioned::kKeySet:
      send_statustext(mav::kSeverityInfo, QUAD_TEXT("signing: key set"));
      break;
    case RadioSigning::Provisioned::kSigningOff:
      send_statustext(mav::kSeverityWarning, QUAD_TEXT("signing: key removed"));
      break;
    case RadioSigning::Provisioned::kStorageFailed:
      send_statustext(mav::kSeverityError, QUAD_TEXT("signing: key in use, not stored"));
      break;
  }
}

void FlightApp::on_command(uint8_t port, const mav::CommandLong& cmd) {
  if (cmd.target_system != kVehicleSystemId && cmd.target_system != 0) return;
  ++counters_.commands;
  const ModeInputs in = mode_inputs();
  Command c;
  switch (cmd.command) {
    case mav::kCmdComponentArmDisarm:
      c = cmd.param1 >= 0.5f ? Command::kArm : (cmd.param2 == kForceDisarmMagic ? Command::kForceDisarm : Command::kDisarm);
      break;
    case mav::kCmdNavLand:
      c = Command::kLand;
      break;
    case mav::kCmdDoSetMode:
      // Only the exact values 0..3 are modes (and a NaN or huge float must not reach the int cast).
      switch (cmd.param2 >= 0.0f && cmd.param2 <= 3.0f && cmd.param2 == static_cast<float>(static_cast<int>(cmd.param2))
                  ? static_cast<int>(cmd.param2)
                  : -1) {
        case static_cast<int>(FlightMode::kDisarmed): c = Command::kDisarm; break;
        case static_cast<int>(FlightMode::kManual): c = Command::kManual; break;
        case static_cast<int>(FlightMode::kAuto): c = Command::kAuto; break;
        case static_cast<int>(FlightMode::kLanding): c = Command::kLand; break;
        default:
          send_ack(port, cmd.command, mav::kResultDenied);
          send_statustext(mav::kSeverityWarning, QUAD_TEXT("unknown custom mode"));
          return;
      }
      break;
    default:
      send_ack(port, cmd.command, mav::kResultUnsupported);
      return;
  }
  const Transition t = modes_.command(c, in);
  send_ack(port, cmd.command, t.accepted ? mav::kResultAccepted : mav::kResultDenied);
  handle_transition(t);
}

void FlightApp::on_param_read(uint8_t port, const mav::ParamRequestRead& msg) {
  int16_t index = msg.param_index;
  if (index < 0) index = param_find(msg.param_id);
  if (index < 0 || index >= kParamCount) return;  // MAVLink: unknown parameters get no answer
  send_param(port, static_cast<uint8_t>(index));
}

void FlightApp::on_param_set(uint8_t port, const mav::ParamSet& msg) {
  const int16_t index = param_find(msg.param_id);
  if (index < 0) {
    char name[kParamNameLength + 1];
    memcpy(name, msg.param_id, kParamNameLength);
    name[kParamNameLength] = '\0';
    send_statustext((StatusLine(mav::kSeverityWarning) << QUAD_TEXT("no such param: ") << name).message());
    return;
  }
  const uint8_t i = static_cast<uint8_t>(index);
  Params candidate = params_;
  const ParamError e = candidate.set(i, msg.param_value);
  const char* error = nullptr;
  if (e != ParamError::kNone) {
    const ParamInfo info = param_info(i);
    send_statustext((StatusLine(mav::kSeverityWarning)
               << (e == ParamError::kNotFinite ? QUAD_TEXT("param not finite: ") : QUAD_TEXT("param out of range: "))
               << info.name)
                  .message());
  } else if (!apply_params(candidate, &error)) {
    send_statustext((StatusLine(mav::kSeverityWarning) << QUAD_TEXT("param refused: ") << error).message());
  } else {
    params_ = candidate;
    // The store rewrites only the bytes that differ in the older copy: the value, sequence and CRC.
    if (!params_save_all(io_.storage, params_)) send_statustext(mav::kSeverityError, QUAD_TEXT("param storage write failed"));
  }
  // Always answer with the value now in force, so the sender sees whether its value was taken.
  send_param(port, i);
}

// ---------------------------------------------------------------------------------------------------
// The control iteration

void FlightApp::step(uint32_t t_us, const hal::ImuSample& imu, const hal::MagSample* mag) {
  mark(hal::TracePoint::kStepBegin);
  const uint32_t begin = io_.micros();
  loop_timer_.begin(begin);
  const float dt = step_dt(clock_started_, t_us - last_step_us_, loop_timer_.period_us(), loop_timer_.period_s());
  clock_started_ = true;
  last_step_us_ = t_us;
  now_us_ = t_us;
  ++counters_.iterations;

  // The stage clock counts every iteration (calibration and disarmed ones too); the time each stage
  // covers is accumulated here and taken where it runs.
  stages_.tick();
  correction_dt_ += dt;
  slow_dt_ += dt;
  // The application's own slow work (the hover bias gate, the mode machine, the position trim, landing
  // detection) at the frame rate, in the shaper's iteration: the lightest of a 400 Hz frame. A vision
  // fix in progress takes that iteration instead (its gate in one frame, its update in the next); the
  // frame-rate work then runs in the next frame's, over the time of both (slow_dt_ keeps counting).
  // It gives way at most twice in a row, so that however fast the fixes come the failsafes and the
  // landing detection still run in one frame of three.
  bool slow_now = stages_.runs(kStageShaper);
  if (slow_now) {
    if (filter_.fix_in_progress() && frame_work_deferred_ < kMaxFrameWorkDeferred) {
      fix_step([&] { return filter_.advance_fix(); });
      slow_now = false;
      ++frame_work_deferred_;
    } else {
      frame_work_deferred_ = 0;
    }
  }
  const float slow_dt = slow_dt_;
  if (slow_now) slow_dt_ = 0.0f;

  sensors_ok_ = is_finite(imu.gyro) && is_finite(imu.accel) && plausible_force(imu.accel);
  // Hard and soft iron (thesis eq. 7.5) out before anything reads the field (the default, identity
  // calibration is the field itself).
  hal::MagSample mag_calibrated;
  const hal::MagSample* m = mag;
  if (mag != nullptr && !mag_cal_identity_) {
    mag_calibrated.field = mag_cal_.apply(mag->field);
    m = &mag_calibrated;
  }
  if (!calibration_.done()) {
    calibrate(imu, m);
  } else {
    // Clipped gyro axes come back held at their last good value (imu_clip.h); the biases come off after.
    const Vec3 gyro = imu_clip_.update(imu, dt);
    report_clipping();
    const Vec3 accel = imu.accel - bias_.bias.accel;
    const bool accel_valid = !imu_clip_.accel_clipped();
    if (slow_now) accel_bias_.update(accel, accel_valid && hovering(), slow_dt);
    // The learned bias has z = +0: accel.z - 0.0f is accel.z itself (IEEE: x - (+0) = x, -0 included).
    const Vec3 b = accel_bias_.bias();
    estimate(gyro - bias_.bias.gyro, Vec3{accel.x - b.x, accel.y - b.y, accel.z}, accel_valid, m, dt);
  }
  if (stages_.runs(kStageCorrect)) correction_dt_ = 0.0f;  // taken by estimate(), or nothing to correct in calibration

  if (slow_now) handle_transition(modes_.update(mode_inputs(false)));
  // A storage write blocks the AVR's loop for milliseconds: the signing clock is saved on the ground.
  if (!modes_.armed()) radio_.persist_clock(io_.storage, now_us_, false);
  control(dt, slow_now, slow_dt);
  mark(modes_.mode() == FlightMode::kDisarmed ? hal::TracePoint::kControlIdle : hal::TracePoint::kControlFlown);
  if (slow_now) detect_landing(slow_dt);
  telemetry();

  if (param_stream_next_ >= 0) {
    send_param(param_stream_port_, static_cast<uint8_t>(param_stream_next_));
    if (++param_stream_next_ >= kParamCount) param_stream_next_ = -1;
  }
  loop_timer_.end(io_.micros());
  mark(hal::TracePoint::kStepEnd);
}

// Hovering still in AUTO: airborne, the shaped setpoint at rest and the vehicle slow, so the mean
// horizontal specific force is the accelerometer's bias (hover_accel_bias.h). Uses the last
// iteration's setpoint and estimate.
bool FlightApp::hovering() const {
  if (modes_.mode() != FlightMode::kAuto || landed_) return false;
  if (moving_axes(setpoint_.v_d) != 0u) return false;
  return slow_for_hover(filter_.velocity());
}

void FlightApp::calibrate(const hal::ImuSample& imu, const hal::MagSample* mag) {
  switch (calibration_.add(now_us_, imu.gyro, imu.accel, mag != nullptr ? &mag->field : nullptr)) {
    case BootCalibration::Event::kCollecting:
      return;
    case BootCalibration::Event::kWindowRejected:
      send_statustext(mav::kSeverityWarning, rejection_text(calibration_.rejection()));
      return;
    case BootCalibration::Event::kDone:
      break;
  }
  bias_ = calibration_.result();
  // With the biases removed the mean specific force is -g e_z: level; the heading comes from the
  // magnetometer (TRIAD), or is 0 without one.
  const Vec3 down_force{0.0f, 0.0f, -kGravity};
  if (!bias_.mag_valid || !observer_.initialize(down_force, bias_.mag_mean)) {
    observer_.reset(Quat::identity(), Vec3{});
  } else {
    // initialize() learned the field with magnetic north as x: turn it by the declination and take the
    // TRIAD attitude against the true-north reference.
    mag_ref_magnetic_ = observer_.params().mag_ref_ned;
    mag_ref_learned_ = true;
    est::ObserverParams op = observer_.params();
    op.mag_ref_from_init = false;
    op.mag_ref_ned = decline(mag_ref_magnetic_, params_.get(kMagDecl));
    observer_.set_params(op);
    observer_.initialize(down_force, bias_.mag_mean);
    observer_.reset(observer_.attitude(), Vec3{});
  }
  send_statustext(mav::kSeverityInfo, QUAD_TEXT("calibrated, ready to arm"));
}

void FlightApp::report_clipping() {
  gyro_clipped_since_status_ = gyro_clipped_since_status_ || imu_clip_.gyro_clipped();
  accel_clipped_since_status_ = accel_clipped_since_status_ || imu_clip_.accel_clipped();
  counters_.imu_clipped_samples = imu_clip_.clipped_samples();
  counters_.imu_clip_bursts = imu_clip_.bursts();
  if (!imu_clip_.burst_started()) return;
  const Decimal burst(imu_clip_.bursts());
  send_statustext((StatusLine(mav::kSeverityWarning) << QUAD_TEXT("IMU clipping: rates held, burst ") << burst.c_str())
                      .message());
}

void FlightApp::estimate(const Vec3& gyro, const Vec3& accel, bool accel_valid, const hal::MagSample* mag, float dt) {
  if (stages_.runs(kStageCorrect)) {
    // A magnetometer sample that arrived since the last correction counts if this iteration has none.
    const Vec3* field = mag != nullptr ? &mag->field : (mag_pending_ ? &pending_mag_ : nullptr);
    const Vec3 zero;
    // Without a valid accelerometer the observer gets a zero specific force, which its norm gate refuses:
    // no gravity correction from this sample (the gyro still propagates).
    const Vec3& a = accel_valid ? accel : zero;
    const Vec3& f = field != nullptr ? *field : zero;
    if (stages_.per_frame() > 1) {
      observer_.correct(gyro, a, f, field != nullptr, dt, correction_dt_);
    } else {
      observer_.update(gyro, a, f, field != nullptr, dt);
    }
    mag_pending_ = false;
  } else {
    // Between corrections the gyro alone carries the attitude, with the last innovation held.
    if (mag != nullptr) {
      pending_mag_ = mag->field;
      mag_pending_ = true;
    }
    observer_.propagate(gyro, dt);
  }
  history_.push(now_us_, observer_.attitude());
  // thesis eq. 8.7: u = g e_z + R a_B, with a_B the mean specific force over the iterations since the
  // last prediction and R the observer's DCM: this iteration's at 100 Hz; at a faster loop the rotation
  // the last correction started from, the middle of the four samples the mean covers.
  // A clipped accelerometer's samples are left out; with none valid, the last good kinematic
  // acceleration stands in while the clip guard is healthy, then none (the filter coasts on its
  // velocity; the estimator failsafe is already landing).
  if (accel_valid) {
    if (accel_count_ == 0) {
      accel_sum_ = accel;  // the first term after a prediction, without three additions to zero
    } else {
      accel_sum_ += accel;
    }
    ++accel_count_;
  }
  if (!stages_.runs(kStagePredict)) return;
  if (accel_count_ > 0) {
    // One sample (a 100 Hz loop) is the sum itself, exactly, without the division and three
    // multiplications (1 100 cycles on the AVR).
    const Vec3 mean = accel_count_ == 1 ? accel_sum_ : accel_sum_ * (1.0f / static_cast<float>(accel_count_));
    last_good_kinematic_accel_ = est::kinematic_acceleration(observer_.dcm(), mean);
  }
  filter_.predict(accel_count_ > 0 || imu_clip_.healthy() ? last_good_kinematic_accel_ : Vec3{}, now_us_);
  accel_count_ = 0;  // the next term replaces accel_sum_
}

ModeInputs FlightApp::mode_inputs(bool with_throttle) const {
  ModeInputs in;
  in.now_us = now_us_;
  in.estimator_converged = calibration_.done() && observer_.initialized();
  const Vec3 v = filter_.velocity();
  // An IMU clipping for longer than IMU_CLIP_HOLD leaves the attitude on guessed rates: unhealthy.
  in.estimator_healthy = in.estimator_converged && imu_clip_.healthy() && is_finite(observer_.attitude()) &&
                         is_finite(filter_.position()) && healthy_speed(v);
  in.sensors_healthy = sensors_ok_;
  in.rc_seen = rc_seen_;
  in.rc_time_us = rc_time_us_;
  if (with_throttle) in.rc_throttle = ctrl::throttle_to_unit(sticks_.throttle);
  in.vision_seen = vision_seen_;
  in.vision_time_us = vision_time_us_;
  in.landed = landed_;
  return in;
}

void FlightApp::handle_transition(const Transition& t) {
  if (t.reason == Reason::kNone) return;
  if (t.changed) enter_mode(t.from, t.to);
  const bool failsafe = t.reason == Reason::kFailsafeVisionLost || t.reason == Reason::kFailsafeRcLost ||
                        t.reason == Reason::kFailsafeEstimator;
  const uint8_t severity = failsafe ? mav::kSeverityCritical : (t.accepted ? mav::kSeverityInfo : mav::kSeverityWarning);
  StatusLine line(severity);
  if (t.changed) line << mode_name(t.to) << QUAD_TEXT(": ");
  send_statustext((line << reason_text(t.reason)).message());
}

void FlightApp::enter_mode(FlightMode from, FlightMode to) {
  const Vec3 p = filter_.position();
  const float yaw = yaw_of(observer_.attitude());
  switch (to) {
    case FlightMode::kDisarmed:
      landed_ = true;
      radio_.persist_clock(io_.storage, now_us_, true);
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
      shaper_.reset(p);
      shaper_.set_target(p);
      // What the shaper gives at rest on its target (p_d = p, v_d = a_d = 0), so a position loop that
      // runs before the shaper's next step (above 100 Hz) holds here.
      setpoint_ = ctrl::PositionSetpoint{};
      setpoint_.p_d = p;
      setpoint_.yaw_d = yaw;
      break;
    case FlightMode::kLanding:
      setpoint_.p_d = p;
      setpoint_.yaw_d = yaw;
      landed_for_s_ = 0.0f;
      break;
  }
}

void FlightApp::control(float dt, bool slow_now, float slow_dt) {
  ctrl::VehicleState s;
  s.p = filter_.position();
  s.v = filter_.velocity();
  s.q = observer_.attitude();
  s.omega = observer_.rate();

  // The position loop in its own iteration of a faster loop (every iteration at 100 Hz), and at once in
  // the first iteration of a mode that uses it, so the attitude loop never flies another mode's command.
  const FlightMode mode = modes_.mode();
  const bool entered = mode != outer_mode_;
  const bool outer_now = stages_.runs(kStagePositionLoop) || entered;
  outer_mode_ = mode;

  const ctrl::CascadeOutput* out = nullptr;
  switch (mode) {
    case FlightMode::kDisarmed:
      break;
    case FlightMode::kManual:
      // A pulse outside the receiver's range keeps the previous command; the RC failsafe decides.
      manual_.update(sticks_, dt);
      out = &cascade_.step_attitude(s, manual_.command());
      break;
    case FlightMode::kAuto: {
      if (slow_now) shaper_.update(slow_dt, setpoint_);
      // The trim learns only in the air (on the ground the error is the ground's doing), and not along an
      // axis the shaped setpoint is moving on (a move's tracking lag is not an offset).
      if (slow_now && !landed_) {
        const uint8_t moving = moving_axes(setpoint_.v_d);
        const bool learn[3] = {(moving & 1u) == 0u, (moving & 2u) == 0u, (moving & 4u) == 0u};
        trim_.update(s.p - setpoint_.p_d, learn, slow_dt);
      }
      if (!outer_now) break;
      ctrl::PositionSetpoint sp = setpoint_;
      sp.a_d += trim_.accel();
      out = &cascade_.step(s, sp);
      break;
    }
    case FlightMode::kLanding: {
      if (!outer_now) break;
      // Descend at LAND_SPEED. Holding position: the horizontal target stays where the landing began.
      // Level: the horizontal errors are zeroed, so eq. 8.20 asks for no horizontal acceleration and
      // the attitude stays level (no trust in a position without vision).
      ctrl::PositionSetpoint sp = setpoint_;
      sp.p_d.z = s.p.z;
      sp.v_d = Vec3{0.0f, 0.0f, params_.get(kLandSpeed)};
      sp.a_d = Vec3{0.0f, 0.0f, trim_.accel_z()};  // the learned vertical trim, frozen
      if (modes_.land_level()) {
        sp.p_d.x = s.p.x;
        sp.p_d.y = s.p.y;
        sp.v_d.x = s.v.x;
        sp.v_d.y = s.v.y;
      }
      out = &cascade_.step(s, sp);
      break;
    }
  }
  // Between two runs of the position loop the attitude loop flies its last thrust and attitude.
  if (out == nullptr && !outer_now && (mode == FlightMode::kAuto || mode == FlightMode::kLanding)) {
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

void FlightApp::detect_landing(float dt) {
  if (!modes_.armed()) {
    landed_ = true;
    landed_for_s_ = 0.0f;
    return;
  }
  // On the ground the commanded descent cannot happen: the estimated vertical speed stays near zero
  // while the controller, pushing down, asks for clearly less than hover thrust.
  // The hover thrust the trim has learned: a_trim < 0 (up) means the vehicle needs more than the model.
  // LAND_VZ_MAX >= 0.05 (its range): |v_z| < it on the bit pattern; the thrust test only when that holds.
  bool quiet = abs_below(filter_.velocity().z, params_.get(kLandVzMax));
  if (quiet) {
    const float hover_scale = 1.0f - trim_.accel_z() * (1.0f / kGravity);
    quiet = last_thrust_ < land_thrust_max_ * hover_scale;
  }
  landed_for_s_ = quiet ? landed_for_s_ + dt : 0.0f;
  if (landed_for_s_ >= params_.get(kLandTime)) landed_ = true;
  else if (!quiet) landed_ = false;
}

// ---------------------------------------------------------------------------------------------------
// Sending

// Only the payload depends on the message type; the frame is finished, signed and written by transmit()
// (one copy of that code, not one per message type: AVR flash).
template <class Msg>
void FlightApp::send(uint8_t port, const Msg& msg) {
  uint8_t buffer[mav::max_frame_length<Msg>(true)];
  mav::write_payload(msg, buffer);
  transmit(port, Msg::kId, Msg::kCrcExtra, Msg::kLength, buffer);
}

void FlightApp::transmit(uint8_t port, uint32_t message_id, uint8_t crc_extra, uint8_t full_length, uint8_t* buffer) {
  const size_t n = port == hal::kUart2 ? radio_.finish(senders_[port], message_id, crc_extra, full_length, buffer)
                                       : senders_[port].finish(message_id, crc_extra, full_length, buffer);
  if (n == 0) return;
  const uint16_t written = io_.write(port, buffer, static_cast<uint16_t>(n));
  counters_.tx_dropped_bytes += static_cast<uint32_t>(n - written);
}

template <class Msg>
void FlightApp::broadcast(const Msg& msg) {
  for (uint8_t port = 0; port < hal::kPortCount; ++port) send(port, msg);
}

uint8_t FlightApp::base_mode() const {
  uint8_t mode = mav::kModeFlagCustomModeEnabled;
  if (modes_.armed()) mode |= mav::kModeFlagSafetyArmed;
  if (hil_) mode |= mav::kModeFlagHilEnabled;
  return mode;
}

void FlightApp::send_actuators(uint64_t time_usec) {
  mav::HilActuatorControls out;
  out.time_usec = time_usec;
  for (uint8_t i = 0; i < hal::kMotorCount; ++i) out.controls[i] = motors_[i];
  out.mode = base_mode();
  // One answer per HIL_SENSOR, stamped with its time, in both modes; the flag says which one the
  // simulator asked for (HIL_LOCKSTEP), as PX4's does.
  out.flags = params_.get(kHilLockstep) >= 0.5f ? mav::kHilActuatorControlsFlagLockstep : 0;
  send(hal::kUart0, out);
}

void FlightApp::send_statustext(uint8_t severity, FlashText text) { send_statustext((StatusLine(severity) << text).message()); }

void FlightApp::send_statustext(const mav::Statustext& msg) {
  broadcast(msg);
  if (io_.console != nullptr) io_.console(msg.severity, msg.text, static_cast<uint8_t>(strnlen(msg.text, sizeof msg.text)));
}

bool FlightApp::led(uint32_t now_us) const {
  if (modes_.armed()) return true;
  const uint32_t half_period_us = calibration_.done() ? 500000u : 100000u;
  return ((now_us / half_period_us) & 1u) == 0u;
}

void FlightApp::send_param(uint8_t port, uint8_t index) {
  const ParamInfo info = param_info(index);
  mav::ParamValue msg;
  msg.param_value = params_.get(index);
  msg.param_count = kParamCount;
  msg.param_index = index;
  copy_name(msg.param_id, info.name);
  msg.param_type = mav::kParamTypeReal32;
  send(port, msg);
}

void FlightApp::send_ack(uint8_t port, uint16_t command, uint8_t result) {
  mav::CommandAck ack;
  ack.command = command;
  ack.result = result;
  send(port, ack);
}

void FlightApp::telemetry() {
  // The 32-bit division (about 600 cycles on the AVR) only for the messages that carry the time.
  if (heartbeat_rate_.tick()) {
    mav::Heartbeat hb;
    hb.custom_mode = static_cast<uint32_t>(modes_.mode());
    hb.type = mav::kMavTypeQuadrotor;
    hb.autopilot = mav::kMavAutopilotGeneric;
    hb.base_mode = base_mode();
    if (!calibration_.done()) hb.system_status = mav::kStateCalibrating;
    else if (modes_.mode() == FlightMode::kLanding && modes_.land_level()) hb.system_status = mav::kStateCritical;
    else hb.system_status = modes_.armed() ? mav::kStateActive : mav::kStateStandby;
    broadcast(hb);
  }
  if (attitude_rate_.tick()) {
    mav::AttitudeQuaternion att;
    att.time_boot_ms = now_us_ / 1000u;
    const Quat& q = observer_.attitude();
    att.q1 = q.w;
    att.q2 = q.x;
    att.q3 = q.y;
    att.q4 = q.z;
    const Vec3& w = observer_.rate();
    att.rollspeed = w.x;
    att.pitchspeed = w.y;
    att.yawspeed = w.z;
    broadcast(att);
  }
  if (position_tel_rate_.tick()) {
    mav::LocalPositionNed pos;
    pos.time_boot_ms = now_us_ / 1000u;
    const Vec3 p = filter_.position();
    const Vec3 v = filter_.velocity();
    pos.x = p.x;
    pos.y = p.y;
    pos.z = p.z;
    pos.vx = v.x;
    pos.vy = v.y;
    pos.vz = v.z;
    broadcast(pos);
  }
  if (status_rate_.tick()) {
    mav::SysStatus st;
    const ModeInputs in = mode_inputs();
    st.onboard_control_sensors_present = kSensorGyro | kSensorAccel | kSensorMag | kSensorVision | kSensorRc | kSensorAhrs;
    st.onboard_control_sensors_enabled = st.onboard_control_sensors_present;
    uint32_t health = 0;
    // A clip anywhere in the status period clears its sensor's bit for that period.
    if (sensors_ok_ && !gyro_clipped_since_status_) health |= kSensorGyro;
    if (sensors_ok_ && !accel_clipped_since_status_) health |= kSensorAccel;
    gyro_clipped_since_status_ = false;
    accel_clipped_since_status_ = false;
    if (bias_.mag_valid) health |= kSensorMag;
    if (modes_.vision_fresh(in)) health |= kSensorVision;
    if (modes_.rc_fresh(in)) health |= kSensorRc;
    if (in.estimator_healthy) health |= kSensorAhrs;
    st.onboard_control_sensors_health = health;
    st.load = loop_timer_.load_permille();
    st.voltage_battery = UINT16_MAX;  // not measured
    st.current_battery = -1;
    st.battery_remaining = -1;
    uint32_t errors = 0;
    for (const mav::Parser& p : parsers_) errors += p.stats().bad_checksum + p.stats().bad_length;
    st.errors_comm = saturate16(errors);
    const uint32_t lost = parsers_[hal::kUart0].stats().sequence_lost + parsers_[hal::kUart2].stats().sequence_lost;
    const uint32_t received = parsers_[hal::kUart0].stats().frames_accepted + parsers_[hal::kUart2].stats().frames_accepted;
    // In 0.01 %; float, so the AVR needs no 64-bit division.
    st.drop_rate_comm = static_cast<uint16_t>(
        received + lost == 0 ? 0.0f : 10000.0f * static_cast<float>(lost) / static_cast<float>(received + lost));
    st.errors_count1 = saturate16(loop_timer_.overruns());
    st.errors_count2 = saturate16(counters_.fixes_rejected);
    st.errors_count3 = saturate16(counters_.tx_dropped_bytes);
    const uint32_t rejected = radio_.rejected();
    st.errors_count4 = saturate16(rejected);
    broadcast(st);
    // At most one line per status period however many frames a stranger sends.
    if (rejected != radio_rejected_reported_) {
      radio_rejected_reported_ = rejected;
      send_statustext(mav::kSeverityWarning, QUAD_TEXT("signing: radio frames rejected"));
    }
  }
}

}  // namespace fw
}  // namespace quad
