#include "quad/firmware/telemetry.h"

#include "quad/firmware/app.h"

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

// A counter in a 16-bit SYS_STATUS field: saturated (one out-of-line copy, not five inline).
__attribute__((noinline)) uint16_t saturate16(uint32_t n) { return static_cast<uint16_t>(n > UINT16_MAX ? UINT16_MAX : n); }

uint8_t system_status(const FlightApp& app) {
  if (!app.calibrated()) return mav::kStateCalibrating;
  if (app.mode() == FlightMode::kLanding && app.control().land_level()) return mav::kStateCritical;
  return app.armed() ? mav::kStateActive : mav::kStateStandby;
}

}  // namespace

uint8_t base_mode(bool armed, bool hil) {
  uint8_t mode = mav::kModeFlagCustomModeEnabled;
  if (armed) mode |= mav::kModeFlagSafetyArmed;
  if (hil) mode |= mav::kModeFlagHilEnabled;
  return mode;
}

uint8_t landed_state(bool armed, bool landed, FlightMode mode) {
  if (!armed || landed) return mav::kLandedStateOnGround;
  return mode == FlightMode::kLanding ? mav::kLandedStateLanding : mav::kLandedStateInAir;
}

void Telemetry::configure(const Params& p, float loop_hz) {
  // One telemetry stream per iteration (scheduler.h: an iteration that sent all four took 45 000 more
  // cycles on the AVR than one that sent none): the slots keep the default rates apart, send_next()
  // spreads any others, so rates that add up to more than the loop rate share it.
  due_ = 0;
  heartbeat_rate_.configure(p.get(kTelHbHz), loop_hz, 1);
  attitude_rate_.configure(p.get(kTelAttHz), loop_hz, 0);
  position_rate_.configure(p.get(kTelPosHz), loop_hz, 5);
  status_rate_.configure(p.get(kTelSysHz), loop_hz, 3);
  extended_state_rate_.configure(p.get(kTelHbHz), loop_hz, 7);
  estimator_rate_.configure(p.get(kTelEstHz), loop_hz, 9);
}

void Telemetry::count() {
  if (heartbeat_rate_.tick()) due_ |= kHeartbeat;
  if (attitude_rate_.tick()) due_ |= kAttitude;
  if (position_rate_.tick()) due_ |= kPosition;
  if (status_rate_.tick()) due_ |= kStatus;
  if (extended_state_rate_.tick()) due_ |= kExtendedState;
  if (estimator_rate_.tick()) due_ |= kEstimatorStatus;
}

void Telemetry::send_next(const FlightApp& app, GroundLink& link) {
  if (due_ == 0) return;
  // The lowest bit: a stream that waited is sent before one that came due later only in this order,
  // and at the default rates streams never fall due in the same iteration (their slots).
  const Stream stream = static_cast<Stream>(due_ & static_cast<uint8_t>(-due_));
  due_ = static_cast<uint8_t>(due_ & ~stream);
  send(stream, app, link);
}

void Telemetry::send(Stream stream, const FlightApp& app, GroundLink& link) {
  if (stream == kHeartbeat) {
    mav::Heartbeat hb;
    hb.custom_mode = static_cast<uint32_t>(app.mode());
    hb.type = mav::kMavTypeQuadrotor;
    hb.autopilot = mav::kMavAutopilotGeneric;
    hb.base_mode = base_mode(app.armed(), app.hil());
    hb.system_status = system_status(app);
    link.broadcast(hb);
  } else if (stream == kAttitude) {
    // The 32-bit division (about 600 cycles on the AVR) only for the messages that carry the time.
    mav::AttitudeQuaternion att;
    att.time_boot_ms = app.now_us() / 1000u;
    const Quat q = app.attitude();
    att.q1 = q.w;
    att.q2 = q.x;
    att.q3 = q.y;
    att.q4 = q.z;
    const Vec3 w = app.estimator().rate();
    att.rollspeed = w.x;
    att.pitchspeed = w.y;
    att.yawspeed = w.z;
    link.broadcast(att);
  } else if (stream == kPosition) {
    mav::LocalPositionNed pos;
    pos.time_boot_ms = app.now_us() / 1000u;
    const Vec3 p = app.position();
    const Vec3 v = app.velocity();
    pos.x = p.x;
    pos.y = p.y;
    pos.z = p.z;
    pos.vx = v.x;
    pos.vy = v.y;
    pos.vz = v.z;
    link.broadcast(pos);
  } else if (stream == kStatus) {
    send_status(app, link);
  } else if (stream == kEstimatorStatus) {
    send_estimator_status(app, link);
  } else {
    mav::ExtendedSysState ext;
    ext.vtol_state = mav::kVtolStateUndefined;
    ext.landed_state = landed_state(app.armed(), app.control().landed(), app.mode());
    link.broadcast(ext);
  }
}

// The estimation layer's flags are MAVLink's ESTIMATOR_STATUS_FLAGS.
static_assert(est::kEstAttitude == mav::kEstimatorAttitude && est::kEstVelocityHoriz == mav::kEstimatorVelocityHoriz &&
                  est::kEstVelocityVert == mav::kEstimatorVelocityVert && est::kEstPosHorizRel == mav::kEstimatorPosHorizRel &&
                  est::kEstPosVertAbs == mav::kEstimatorPosVertAbs && est::kEstConstPosMode == mav::kEstimatorConstPosMode &&
                  est::kEstPredPosHorizRel == mav::kEstimatorPredPosHorizRel && est::kEstAccelError == mav::kEstimatorAccelError,
              "ESTIMATOR_STATUS_FLAGS");

void Telemetry::send_estimator_status(const FlightApp& app, GroundLink& link) {
  const EstimatorReport r = app.estimator().report();
  mav::EstimatorStatus st;
  st.time_usec = app.timesync_us();
  st.flags = r.flags;
  st.vel_ratio = r.vel_ratio;
  st.pos_horiz_ratio = r.pos_horiz_ratio;
  st.pos_vert_ratio = r.pos_vert_ratio;
  st.mag_ratio = r.mag_ratio;
  st.pos_horiz_accuracy = r.pos_horiz_accuracy;
  st.pos_vert_accuracy = r.pos_vert_accuracy;
  link.broadcast(st);
}

void Telemetry::send_status(const FlightApp& app, GroundLink& link) {
  mav::SysStatus st;
  const ModeInputs in = app.mode_inputs(false);
  st.onboard_control_sensors_present = kSensorGyro | kSensorAccel | kSensorMag | kSensorVision | kSensorRc | kSensorAhrs;
  st.onboard_control_sensors_enabled = st.onboard_control_sensors_present;
  const bool sensors_ok = app.estimator().sensors_ok();
  uint32_t health = 0;
  // A clip anywhere in the status period clears its sensor's bit for that period.
  if (sensors_ok && !gyro_clipped_) health |= kSensorGyro;
  if (sensors_ok && !accel_clipped_) health |= kSensorAccel;
  gyro_clipped_ = false;
  accel_clipped_ = false;
  if (app.estimator().mag_valid()) health |= kSensorMag;
  if (app.control().vision_fresh(in)) health |= kSensorVision;
  if (app.control().rc_fresh(in)) health |= kSensorRc;
  if (in.estimator_healthy) health |= kSensorAhrs;
  st.onboard_control_sensors_health = health;
  st.load = app.loop_timer().load_permille();
  st.voltage_battery = UINT16_MAX;  // not measured
  st.current_battery = -1;
  st.battery_remaining = -1;
  uint32_t errors = 0;
  for (uint8_t port = 0; port < hal::kPortCount; ++port) {
    errors += link.parser(port).stats().bad_checksum + link.parser(port).stats().bad_length;
  }
  st.errors_comm = saturate16(errors);
  const mav::ParserStats& usb = link.parser(hal::kUart0).stats();
  const mav::ParserStats& radio = link.parser(hal::kUart2).stats();
  const uint32_t lost = usb.sequence_lost + radio.sequence_lost;
  const uint32_t received = usb.frames_accepted + radio.frames_accepted;
  // In 0.01 %; float, so the AVR needs no 64-bit division.
  st.drop_rate_comm = static_cast<uint16_t>(
      received + lost == 0 ? 0.0f : 10000.0f * static_cast<float>(lost) / static_cast<float>(received + lost));
  st.errors_count1 = saturate16(app.loop_timer().overruns());
  st.errors_count2 = saturate16(app.fixes_rejected());
  st.errors_count3 = saturate16(link.counters().tx_dropped_bytes);
  const uint32_t rejected = link.radio_signing().rejected();
  st.errors_count4 = saturate16(rejected);
  link.broadcast(st);
  // At most one line per status period however many frames a stranger sends.
  if (rejected != radio_rejected_reported_) {
    radio_rejected_reported_ = rejected;
    link.send_statustext(mav::kSeverityWarning, QUAD_TEXT("signing: radio frames rejected"));
  }
}

}  // namespace fw
}  // namespace quad
