#include "quad/firmware/app.h"

#include "quad/firmware/app_checks.h"
#include "quad/firmware/status_text.h"

namespace quad {
namespace fw {
namespace mav = ::quad::mavlink;

namespace {

// Fixes refused in a row before the one taken that make the jump worth a STATUSTEXT (one lost outlier
// is routine; 3 at 30 Hz is 0.1 s of a fix that disagrees with the estimate).
constexpr uint8_t kJumpReportRejections = 3;

FlashText rejection_text(est::CalibrationStatus status) {
  switch (status) {
    case est::CalibrationStatus::kMoved: return QUAD_TEXT("calibration: vehicle moved, again");
    case est::CalibrationStatus::kTurning: return QUAD_TEXT("calibration: vehicle turning, again");
    case est::CalibrationStatus::kNotLevel: return QUAD_TEXT("calibration: not level, again");
    case est::CalibrationStatus::kNonFinite: return QUAD_TEXT("calibration: bad sample, again");
    default: return QUAD_TEXT("calibration: again");
  }
}

bool is_failsafe(Reason reason) {
  return reason == Reason::kFailsafeVisionLost || reason == Reason::kFailsafeRcLost ||
         reason == Reason::kFailsafeEstimator;
}

}  // namespace

void FlightApp::init(const AppIo& io) {
  micros_ = io.micros;
  trace_ = io.trace;
  hil_sensor_ = io.hil_sensor;
  hil_context_ = io.hil_context;
  link_.init(GroundLink::Io{io.storage, io.write, io.console, log_statustext, this, io.log_store, io.tx_free},
             &params_);
  logger_.init(io.log_store);
  store_status_ = params_load(io.storage, params_);
  const bool key_ok = link_.load_signing_key();
  const char* error = nullptr;
  if (!apply_params(params_, &error)) {
    // Values that pass their ranges but not a part's own checks (a combination): defaults.
    params_.reset_to_defaults();
    apply_params(params_, &error);
    link_.send_statustext((StatusLine(mav::kSeverityError) << QUAD_TEXT("params rejected, defaults: ") << error).message());
  }
  if (store_status_ != StoreStatus::kLoaded) link_.send_statustext(mav::kSeverityWarning, store_status_text(store_status_));
  if (!key_ok) link_.send_statustext(mav::kSeverityError, QUAD_TEXT("signing: key store corrupt, no key"));
  const RadioSigning& radio = link_.radio_signing();
  if (radio.enabled() && !radio.has_key()) link_.send_statustext(mav::kSeverityError, QUAD_TEXT("signing: no key, radio closed"));
  estimator_.restart_calibration();
  link_.send_statustext(mav::kSeverityInfo, QUAD_TEXT("calibrating: keep the vehicle still"));
}

bool FlightApp::apply_params(const Params& p, const char** error) {
  // Every check before any change, so a refused set leaves every part as it was: the estimator's checks
  // change nothing, and flight control takes the set only when all of its own pass.
  const char* bad = estimator_.check(p);
  if (bad == nullptr) bad = control_.configure(p);
  if (bad != nullptr) {
    *error = bad;
    return false;
  }
  const float loop_hz = p.get(kLoopHz);
  estimator_.configure(p, loop_hz);
  link_.configure(p);
  loop_timer_.set_rate_hz(loop_hz);
  schedule_.configure(loop_hz);
  background_.configure(loop_timer_.period_us(), schedule_.fuses_on_arrival());
  telemetry_.configure(p, loop_hz);
  logger_.configure(p, loop_hz);
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

ParamUpdate FlightApp::set_param(uint8_t index, float value) {
  ParamUpdate u;
  Params candidate = params_;
  const ParamError e = candidate.set(index, value);
  if (e != ParamError::kNone) {
    u.status = e == ParamError::kNotFinite ? ParamUpdate::Status::kNotFinite : ParamUpdate::Status::kOutOfRange;
  } else if (!apply_params(candidate, &u.field)) {
    u.status = ParamUpdate::Status::kRefused;
  } else {
    params_ = candidate;
    // The store rewrites only the bytes that differ in the older copy: the value, sequence and CRC.
    if (!params_save_all(link_.storage(), params_)) u.status = ParamUpdate::Status::kNotStored;
    logger_.param_changed(index, value);
  }
  return u;
}

// ---------------------------------------------------------------------------------------------------
// The control iteration

void FlightApp::step(uint32_t t_us, const hal::ImuSample& imu, const hal::MagSample* mag) {
  mark(hal::TracePoint::kStepBegin);
  loop_timer_.begin(micros_());
  const float dt = step_dt(clock_started_, t_us - last_step_us_, loop_timer_.period_us(), loop_timer_.period_s());
  clock_started_ = true;
  last_step_us_ = t_us;
  now_us_ = t_us;

  // A mode entered between iterations (a command) runs the position loop in this one: a waiting fix's
  // step would share it, so the frame-rate work runs and the fix waits a frame.
  const IterationPlan plan = schedule_.next(dt, estimator_.fix_in_progress() && !control_.mode_entered());
  if (plan.fix_step) logger_.vision_fix_result(fix_step([&] { return estimator_.advance_fix(); }));

  const bool hovering = plan.frame_work && control_.hovering(estimator_.velocity());
  estimator_.set_armed(control_.armed());
  const bool on_ground = control_.on_ground();
  const EstimatorEvent event = estimator_.step(t_us, imu, mag, dt, plan, hovering, on_ground);
  report(event);
  mark(hal::TracePoint::kEstimated);

  if (plan.frame_work) report_transition(control_.update_mode(mode_inputs(false)));
  if (!control_.armed()) link_.persist_signing_clock(now_us_, false);
  mark(hal::TracePoint::kModesDone);
  ctrl::VehicleState s;
  s.p = estimator_.position();
  s.v = estimator_.velocity();
  s.q = estimator_.attitude();
  s.omega = estimator_.rate();
  // A mode entered (by a command, or by the mode machine in this iteration) runs the position loop in this
  // iteration whatever its stage: above 100 Hz its telemetry waits for the next one.
  const bool position_loop_forced = plan.multi_rate && control_.mode_entered();
  control_.step(s, dt, plan);
  mark(control_.mode() == FlightMode::kDisarmed ? hal::TracePoint::kControlIdle : hal::TracePoint::kControlFlown);
  if (plan.frame_work) control_.detect_landing(plan.frame_dt, estimator_.velocity().z);

  // The application's own output, spread: one telemetry stream, streamed parameter or log frame per
  // iteration, none beside a vision fix's step (frame_schedule.h) or a position loop out of its turn,
  // and each only when it ends in time (BackgroundBudget); what waits goes in a later iteration.
  // The flight log's records of this iteration go first (they wait at most an iteration; a second wait
  // loses them).
  const bool room = !plan.fix_step && !position_loop_forced;
  const uint16_t records_us = logger_.records_due_us(plan);
  telemetry_.count();
  const bool sent = room && telemetry_.due() &&
                    background_.fits(iteration_elapsed_us(), BackgroundBudget::kTelemetryUs + records_us);
  if (sent) telemetry_.send_next(*this, link_);
  mark(hal::TracePoint::kTelemetryDone);
  if (room && !sent && link_.streaming() && logger_.backlog() <= BackgroundBudget::kStreamLogBacklog &&
      background_.fits(iteration_elapsed_us(), BackgroundBudget::kStreamUs + records_us) &&
      !link_.stream_params()) {
    link_.stream_logs();
  }
  mark(hal::TracePoint::kStreamed);
  logger_.iteration(*this, plan, imu, mag, dt, hovering, on_ground);
  loop_timer_.end(micros_());
  mark(hal::TracePoint::kStepEnd);
  report_overrun();
}

void FlightApp::report_overrun() {
  // Once per flight, after the measured iteration: the operator hears that the loop missed its period
  // while flying (boot and calibration are allowed to); SYS_STATUS keeps counting (errors_count1, load).
  if (!control_.armed()) {
    overrun_reported_ = false;
    return;
  }
  if (overrun_reported_ || loop_timer_.last_exec_us() <= loop_timer_.period_us()) return;
  overrun_reported_ = true;
  const Decimal took(loop_timer_.last_exec_us());
  const Decimal period(loop_timer_.period_us());
  link_.send_statustext((StatusLine(mav::kSeverityWarning) << QUAD_TEXT("loop overrun: ") << took.c_str()
                         << QUAD_TEXT(" us of a ") << period.c_str() << QUAD_TEXT(" us period"))
                            .message());
}

void FlightApp::report(EstimatorEvent event) {
  switch (event) {
    case EstimatorEvent::kNone:
    case EstimatorEvent::kClipBurstStarted:
      break;
    case EstimatorEvent::kCalibrationWindowRejected:
      link_.send_statustext(mav::kSeverityWarning, rejection_text(estimator_.calibration_rejection()));
      return;
    case EstimatorEvent::kCalibrated:
      link_.send_statustext(mav::kSeverityInfo, QUAD_TEXT("calibrated, ready to arm"));
      return;
  }
  if (!estimator_.calibrated()) return;
  // The clip guard ran: latch its flags for SYS_STATUS, one line per burst.
  const ImuClipGuard& clip = estimator_.imu_clip();
  telemetry_.note_clipping(clip.gyro_clipped(), clip.accel_clipped());
  if (event != EstimatorEvent::kClipBurstStarted) return;
  const Decimal burst(clip.bursts());
  link_.send_statustext((StatusLine(mav::kSeverityWarning) << QUAD_TEXT("IMU clipping: rates held, burst ") << burst.c_str())
                            .message());
}

ModeInputs FlightApp::mode_inputs(bool with_throttle) const {
  ModeInputs in;
  in.now_us = now_us_;
  in.estimator_converged = estimator_.converged();
  in.estimator_healthy = estimator_.healthy();
  in.sensors_healthy = estimator_.sensors_ok();
  in.rc_seen = control_.rc_seen();
  in.rc_time_us = control_.rc_time_us();
  if (with_throttle) in.rc_throttle = control_.rc_throttle();
  in.vision_seen = vision_seen_;
  in.vision_time_us = vision_time_us_;
  in.landed = control_.landed();
  in.below_star_view = estimator_.height_above_star() < control_.star_view_height();
  return in;
}

Transition FlightApp::mode_command(Command c) {
  ModeInputs in = mode_inputs();
  if (c == Command::kArm) in.estimator_converged = in.estimator_converged && estimator_.preflight() == Preflight::kReady;
  return control_.command(c, in);
}

void FlightApp::report_transition(const Transition& t) {
  if (t.reason == Reason::kNone) return;
  if (t.changed) {
    const Quat q = estimator_.attitude();
    control_.enter_mode(t.from, t.to, estimator_.position(), to_euler(q).yaw);
    if (t.to == FlightMode::kDisarmed) link_.persist_signing_clock(now_us_, true);
  }
  const uint8_t severity =
      is_failsafe(t.reason) ? mav::kSeverityCritical : (t.accepted ? mav::kSeverityInfo : mav::kSeverityWarning);
  StatusLine line(severity);
  if (t.changed) line << mode_name(t.to) << QUAD_TEXT(": ");
  line << reason_text(t.reason);
  if (t.reason == Reason::kRejectEstimatorNotConverged) line << QUAD_TEXT(": ") << preflight_text(estimator_.preflight());
  link_.send_statustext(line.message());
  logger_.transition(*this, t);
}

void FlightApp::log_statustext(void* app, const mav::Statustext& msg) {
  FlightApp* self = static_cast<FlightApp*>(app);
  self->logger_.statustext(self->now_us_, msg);
}

// ---------------------------------------------------------------------------------------------------
// What the ground link receives

void FlightApp::receive(uint8_t port, const uint8_t* data, uint16_t length, uint32_t now_us) {
  if (!hil()) now_us_ = now_us;
  link_.receive(port, data, length, *this);
}

void FlightApp::hil_frame(const mav::Frame& frame) {
  if (hil_sensor_ != nullptr) hil_sensor_(hil_context_, frame);
}

void FlightApp::rc_input(const ctrl::RcSticks& sticks, uint32_t t_us, const RcSwitches* switches) {
  control_.set_sticks(sticks, t_us);
  if (!control_.rc_switches_enabled() || switches == nullptr) return;
  RcSwitches before;
  if (!switch_edges_.update(*switches, &before)) return;
  if (switches->motors_enabled != before.motors_enabled) {
    report_transition(mode_command(switches->motors_enabled ? Command::kArm : Command::kForceDisarm));
  }
  if (switches->auto_mode != before.auto_mode && control_.armed()) {
    report_transition(mode_command(switches->auto_mode ? Command::kAuto : Command::kManual));
  }
}

void FlightApp::position_target(const Vec3& target, const float* yaw) {
  if (!is_finite(target)) return;
  control_.set_position_target(target);
  if (yaw != nullptr && is_finite(*yaw)) control_.set_yaw_target(*yaw);
}

void FlightApp::position_fix_at(const Vec3& p_ned, uint32_t capture_us, const float* q) {
  LogFixResult logged = LogFixResult::kInvalid;
  if (!is_finite(p_ned)) {
    ++fixes_invalid_;
  } else if (!schedule_.fuses_on_arrival() || estimator_.fix_in_progress()) {
    // Queued for the frame-rate work's iteration (frame_schedule.h).
    const est::FixResult r = estimator_.queue_fix(p_ned, capture_us);
    if (r != est::FixResult::kPending) fix_result(r, false);
    logged = log_fix_result(r, false);
  } else {
    logged = fix_step([&] { return estimator_.fuse_fix(p_ned, capture_us); });
  }
  logger_.vision_fix(now_us_, &p_ned, capture_us, q, logged);
}

template <class Step>
LogFixResult FlightApp::fix_step(Step step) {
  const uint32_t resets_before = estimator_.filter_resets();
  mark(hal::TracePoint::kFixBegin);
  const est::FixResult r = step();
  mark(hal::TracePoint::kFixEnd);
  const bool reset = estimator_.filter_resets() != resets_before;
  if (r != est::FixResult::kPending) fix_result(r, reset);
  return log_fix_result(r, reset);
}

void FlightApp::fix_result(est::FixResult r, bool reset) {
  const bool taken = r == est::FixResult::kFused || r == est::FixResult::kInitialized;
  if (taken && (reset || fixes_rejected_in_a_row_ >= kJumpReportRejections)) {
    // The estimate jumped to a fix it had refused before (a decoy taken for the star, a moved marker,
    // a return from a long outage): not a failsafe, but the operator must hear of it.
    const Decimal n(fixes_rejected_in_a_row_);
    link_.send_statustext((StatusLine(mav::kSeverityWarning) << QUAD_TEXT("position jumped to the fix after ")
                           << n.c_str() << QUAD_TEXT(" rejected"))
                              .message());
  }
  if (taken) {
    ++fixes_fused_;
    fixes_rejected_in_a_row_ = 0;
    // Freshness counts from when the fix is taken on the vehicle clock (its arrival, or a few frames
    // later when queued): a fix delayed by the link is still news.
    vision_seen_ = true;
    vision_time_us_ = now_us_;
  } else {
    ++fixes_rejected_;
    // (One refused because another was still in progress says nothing about the star.)
    if (r != est::FixResult::kRejectedBusy && fixes_rejected_in_a_row_ < 255) ++fixes_rejected_in_a_row_;
  }
}

// ---------------------------------------------------------------------------------------------------

AppCounters FlightApp::counters() const {
  AppCounters c;
  c.iterations = loop_timer_.iterations();  // one end() per step()
  c.fixes_received = fixes_received_;
  c.fixes_fused = fixes_fused_;
  c.fixes_rejected = fixes_rejected_;
  c.fixes_invalid = fixes_invalid_;
  c.tx_dropped_bytes = link_.counters().tx_dropped_bytes;
  c.commands = link_.counters().commands;
  c.imu_clipped_samples = estimator_.imu_clip().clipped_samples();
  c.imu_clip_bursts = estimator_.imu_clip().bursts();
  return c;
}

bool FlightApp::led(uint32_t now_us) const {
  if (control_.armed()) return true;
  const uint32_t half_period_us = estimator_.calibrated() ? 500000u : 100000u;
  return ((now_us / half_period_us) & 1u) == 0u;
}

}  // namespace fw
}  // namespace quad
