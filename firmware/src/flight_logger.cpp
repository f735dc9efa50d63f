#include "quad/firmware/flight_logger.h"

#include "quad/firmware/app.h"

namespace quad {
namespace fw {

namespace {

// Field bytes of each topic's data (the formats in flight_log_definitions.cpp).
constexpr uint8_t kSensorCombinedBytes = 8 + 12 + 12 + 4 + 1 + 1;
constexpr uint8_t kSensorMagBytes = 8 + 12;
constexpr uint8_t kAttitudeBytes = 8 + 16 + 12;
constexpr uint8_t kLocalPositionBytes = 8 + 24 + 36;
constexpr uint8_t kVisionFixBytes = 8 + 8 + 12 + 16 + 1;
constexpr uint8_t kSetpointBytes = 8 + 16;
constexpr uint8_t kMotorsBytes = 8 + 16;
constexpr uint8_t kStatusBytes = 8 + 3;
constexpr uint8_t kLoopTimingBytes = 8 + 16 + 4 + 2;
constexpr uint8_t kEstimatorStatusBytes = 8 + 24 + 2;
// A frame-rate iteration's records, queued together and stored in one append (FlightLogger::iteration).
static_assert(ulog::data_record_bytes(kSensorCombinedBytes) + ulog::data_record_bytes(kAttitudeBytes) +
                      ulog::data_record_bytes(kSensorMagBytes) + ulog::data_record_bytes(kLocalPositionBytes) +
                      ulog::data_record_bytes(kSetpointBytes) + ulog::data_record_bytes(kMotorsBytes) <=
                  UlogWriter::kStagingBytes,
              "an iteration's records must fit the writer's buffer");

float nan() { return __builtin_nanf(""); }

}  // namespace

LogFixResult log_fix_result(est::FixResult r, bool reset) {
  switch (r) {
    case est::FixResult::kFused: return reset ? LogFixResult::kReset : LogFixResult::kFused;
    case est::FixResult::kInitialized: return LogFixResult::kReset;
    case est::FixResult::kRejectedGate: return LogFixResult::kRejectedGate;
    case est::FixResult::kRejectedInvalid: return LogFixResult::kInvalid;
    case est::FixResult::kPending: return LogFixResult::kQueued;
    default: return LogFixResult::kRejectedOld;
  }
}

void FlightLogger::configure(const Params& p, float loop_hz) {
  mode_ = static_cast<LogMode>(static_cast<uint8_t>(p.get(kLogMode) + 0.5f));
  imu_div_ = static_cast<uint8_t>(p.get(kLogImuDiv) + 0.5f);
  timing_rate_.configure(1.0f, loop_hz);
  estimator_rate_.configure(kEstimatorStatusHz, loop_hz);
}

void FlightLogger::count_clock(uint32_t now_us) {
  if (now_us < clock_last_) ++clock_high_;
  clock_last_ = now_us;
}

uint64_t FlightLogger::stamp(uint32_t now_us) {
  count_clock(now_us);
  // The two halves put together in memory: a 64-bit shift is a library loop on the AVR.
  const uint32_t halves[2] = {now_us, clock_high_};
  uint64_t t;
  memcpy(&t, halves, sizeof t);
  return t;
}

void FlightLogger::start(const FlightApp& app) {
  if (!writer_.open(stamp(app.now_us()), 0)) return;
  ++logs_opened_;
  phase_ = kPhaseFormats;
  item_ = 0;
  imu_count_ = 0;
  frame_due_ = false;
  records_deferred_ = 0;
  max_us_ = 0;
  overruns_seen_ = app.loop_timer().overruns();
  dropped_seen_ = writer_.dropped();
  // The definitions follow in the iterations (iteration()): an arming between iterations or in the mode
  // machine leaves them to the background of the next ones.
}

void FlightLogger::iteration(const FlightApp& app, const IterationPlan& plan, const hal::ImuSample& imu,
                             const hal::MagSample* mag, float dt, bool hovering, bool on_ground) {
  if (mode_ == LogMode::kBoot && !boot_log_started_) {
    boot_log_started_ = true;
    start(app);
  }
  const uint32_t t = app.now_us();
  count_clock(t);
  if (!writer_.is_open()) return;
  if (timing_rate_.tick()) timing_due_ = true;
  if (estimator_rate_.tick()) estimator_due_ = true;
  const uint64_t now = stamp(t);
  const LoopTimer& loop = app.loop_timer();
  if (loop.last_exec_us() > max_us_) max_us_ = loop.last_exec_us();
  if (loop.overruns() != overruns_seen_) timing_due_ = true;
  // The definitions and the slow records go where the iteration has room: no fix step, and above 100 Hz
  // not the frame-rate work's iteration either.
  bool spare = !plan.fix_step && !(plan.multi_rate && plan.frame_work);
  if (phase_ != kPhaseData) {
    if (spare || !app.armed()) write_definitions(app);
    if (phase_ != kPhaseData) return;
  }
  if (writer_.dropped() != dropped_seen_) note_dropout(t);
  write_topics(app, plan, now, imu, mag, dt, hovering, on_ground);
  // The slow records (at most one an iteration) wait for an iteration with time left for them.
  if (spare && (timing_due_ || estimator_due_ || queued_result_ != kNoResult)) {
    spare = app.background().fits(app.iteration_elapsed_us(), BackgroundBudget::kSlowRecordsUs);
  }
  if (spare && timing_due_) {
    write_loop_timing(app);
  } else if (spare && estimator_due_) {
    write_estimator_status(app);
  }
  if (spare && queued_result_ != kNoResult) {
    vision_fix(t, &queued_fix_, queued_capture_us_, nullptr, static_cast<LogFixResult>(queued_result_));
    queued_result_ = kNoResult;
  }
  // The iteration's records, and those of the events since the last one, in one append, as far as the
  // iteration has time for them (the rest waits in the writer's buffer for the next iterations).
  writer_.flush(app.background().log_bytes(app.iteration_elapsed_us()));
  writer_.set_room_flush_limit(0xFFFFu);
}

void FlightLogger::write_topics(const FlightApp& app, const IterationPlan& plan, uint64_t now,
                                const hal::ImuSample& imu, const hal::MagSample* mag, float dt, bool hovering,
                                bool on_ground) {
  const BackgroundBudget& background = app.background();
  const uint32_t elapsed = app.iteration_elapsed_us();
  // Above the thesis' rate the iteration's records go only when their composition ends before the
  // deadline; what does not fit waits for the next iteration: the IMU topics log that iteration's sample
  // (one every LOG_IMU_DIV-th iteration on average; at LOG_IMU_DIV 1 the sample is lost, and counted), the
  // frame-rate topics that iteration's state (lost and counted when the next frame-rate work comes first).
  // At the thesis' rate every iteration has its own records, and the period keeps a fix's time after the
  // deadline, which they may take.
  const bool budgeted = plan.multi_rate;
  if (imu_count_ < imu_div_) ++imu_count_;
  if (plan.frame_work) {
    if (frame_due_) writer_.count_drop();
    frame_due_ = true;
  }
  uint32_t records_us = 0;  // the time the records composed below take, above the thesis' rate
  const bool imu_now =
      imu_count_ >= imu_div_ && (!budgeted || background.fits(elapsed, BackgroundBudget::kImuRecordsUs));
  if (imu_now && budgeted) records_us = BackgroundBudget::kImuRecordsUs;
  const bool frame_now = frame_due_ && (!budgeted || background.fits(elapsed + records_us,
                                                                      BackgroundBudget::kFrameRecordsUs));
  if (frame_now && budgeted) records_us += BackgroundBudget::kFrameRecordsUs;
  if (imu_count_ >= imu_div_ && !imu_now) {
    ++records_deferred_;
    if (imu_div_ <= 1) {
      imu_count_ = 0;
      writer_.count_drop();
    }
  }
  if (frame_due_ && !frame_now) ++records_deferred_;
  // A full buffer makes room in the store only as far as the iteration has time after the records.
  writer_.set_room_flush_limit(background.log_bytes(elapsed + records_us));
  if (imu_now) {
    imu_count_ = 0;
    write_imu_topics(app, now, imu, dt, hovering, on_ground);
  }
  if (mag != nullptr) {
    uint8_t* p = writer_.begin_data(kLogSensorMag, kSensorMagBytes);
    if (p != nullptr) {
      UlogFields(p).u64(now).f32(&mag->field.x, 3);
    }
  }
  if (frame_now) {
    frame_due_ = false;
    write_frame_topics(app, now);
  }
}

void FlightLogger::note_dropout(uint32_t now_us) {
  // Records were lost (the writer's buffer full): a dropout message ahead of the next records, as PX4's
  // logger writes, its duration from the first iteration that saw the loss to this one.
  if (!in_dropout_) {
    in_dropout_ = true;
    dropout_start_us_ = now_us;
  }
  const uint32_t ms = (now_us - dropout_start_us_) / 1000u;
  if (!writer_.dropout(static_cast<uint16_t>(ms < 0xFFFFu ? (ms == 0 ? 1u : ms) : 0xFFFFu))) return;
  dropped_seen_ = writer_.dropped();
  in_dropout_ = false;
}

void FlightLogger::write_imu_topics(const FlightApp& app, uint64_t now, const hal::ImuSample& imu, float dt,
                                    bool hovering, bool on_ground) {
  uint8_t* p = writer_.begin_data(kLogSensorCombined, kSensorCombinedBytes);
  if (p != nullptr) {
    UlogFields(p).u64(now).f32(&imu.gyro.x, 3).f32(&imu.accel.x, 3).f32(dt).u8(hovering ? 1 : 0).u8(on_ground ? 1 : 0);
  }
  p = writer_.begin_data(kLogVehicleAttitude, kAttitudeBytes);
  if (p != nullptr) {
    const Quat q = app.attitude();
    const Vec3 bias = app.estimator().gyro_bias();
    UlogFields(p).u64(now).f32(&q.w, 4).f32(&bias.x, 3);
  }
}

void FlightLogger::write_frame_topics(const FlightApp& app, uint64_t now) {
  const StateEstimator& est = app.estimator();
  uint8_t* p = writer_.begin_data(kLogLocalPosition, kLocalPositionBytes);
  if (p != nullptr) {
    const Vec3 pos = est.position(), vel = est.velocity();
    const Vec3 pv = est.position_variance(), vv = est.velocity_variance(), ab = est.filter_accel_bias();
    UlogFields(p).u64(now).f32(&pos.x, 3).f32(&vel.x, 3).f32(&pv.x, 3).f32(&vv.x, 3).f32(&ab.x, 3);
  }
  if (app.armed() && (p = writer_.begin_data(kLogSetpoint, kSetpointBytes)) != nullptr) {
    const ctrl::PositionSetpoint& sp = app.control().setpoint();
    UlogFields(p).u64(now).f32(&sp.p_d.x, 3).f32(sp.yaw_d);
  }
  if ((p = writer_.begin_data(kLogActuatorMotors, kMotorsBytes)) != nullptr) {
    UlogFields(p).u64(now).f32(app.motors(), hal::kMotorCount);
  }
}

void FlightLogger::write_loop_timing(const FlightApp& app) {
  const LoopTimer& loop = app.loop_timer();
  uint8_t* p = writer_.begin_data(kLogLoopTiming, kLoopTimingBytes);
  if (p == nullptr) return;
  timing_due_ = false;
  overruns_seen_ = loop.overruns();
  UlogFields(p)
      .u64(stamp(app.now_us()))
      .u32(loop.iterations())
      .u32(loop.overruns())
      .u32(loop.last_exec_us())
      .u32(max_us_)
      .f32(static_cast<float>(loop.load_permille()) * 1e-3f)
      .bytes(&records_deferred_, sizeof records_deferred_);
}

void FlightLogger::write_estimator_status(const FlightApp& app) {
  uint8_t* p = writer_.begin_data(kLogEstimatorStatus, kEstimatorStatusBytes);
  if (p == nullptr) return;
  estimator_due_ = false;
  const EstimatorReport r = app.estimator().report();
  // The report's six floats are consecutive: vel, pos_horiz, pos_vert, mag ratios, the two accuracies.
  UlogFields(p).u64(stamp(app.now_us())).f32(&r.vel_ratio, 6).bytes(&r.flags, sizeof r.flags);
}

void FlightLogger::write_status(const FlightApp& app) {
  uint8_t* p = writer_.begin_data(kLogVehicleStatus, kStatusBytes);
  if (p == nullptr) return;
  UlogFields(p)
      .u64(stamp(app.now_us()))
      .u8(static_cast<uint8_t>(app.mode()))
      .u8(app.armed() ? 1 : 0)
      .u8(last_reason_);
}

void FlightLogger::transition(const FlightApp& app, const Transition& t) {
  if (!t.changed) return;
  last_reason_ = static_cast<uint8_t>(t.reason);
  if (mode_ == LogMode::kArmed && t.from == FlightMode::kDisarmed && !writer_.is_open()) {
    start(app);
    return;
  }
  if (header_done()) write_status(app);
  if (mode_ != LogMode::kBoot && t.to == FlightMode::kDisarmed) writer_.close();
}

void FlightLogger::statustext(uint32_t now_us, const mavlink::Statustext& msg) {
  if (!header_done()) return;
  uint8_t length = 0;
  while (length < sizeof msg.text && msg.text[length] != '\0') ++length;
  // ULog's levels are the syslog levels as ASCII digits, as MAVLink's severities are.
  writer_.logged_string(static_cast<uint8_t>('0' + msg.severity), stamp(now_us), msg.text, length);
}

void FlightLogger::param_changed(uint8_t index, float value) {
  if (!header_done()) return;
  const ParamInfo info = param_info(index);
  writer_.parameter(info.name, value);
}

void FlightLogger::vision_fix(uint32_t now_us, const Vec3* p_ned, uint32_t capture_us, const float* q,
                              LogFixResult result) {
  if (result == LogFixResult::kQueued) {
    queued_fix_ = *p_ned;
    queued_capture_us_ = capture_us;
    queued_result_ = kNoResult;
  }
  if (!header_done()) return;
  uint8_t* p = writer_.begin_data(kLogVisionFix, kVisionFixBytes);
  if (p == nullptr) return;
  const float none[4] = {nan(), nan(), nan(), nan()};
  if (q != nullptr && q[0] == 0.0f && q[1] == 0.0f && q[2] == 0.0f && q[3] == 0.0f) q = nullptr;
  const Vec3 position = p_ned != nullptr ? *p_ned : Vec3{nan(), nan(), nan()};
  // The capture time on the 64-bit clock: the arrival less how long before it the fix was taken.
  const uint64_t now = stamp(now_us);
  const int32_t age_us = static_cast<int32_t>(now_us - capture_us);
  UlogFields(p)
      .u64(now)
      .u64(static_cast<uint64_t>(static_cast<int64_t>(now) - age_us))
      .f32(&position.x, 3)
      .f32(q != nullptr ? q : none, 4)
      .u8(static_cast<uint8_t>(result));
}


}  // namespace fw
}  // namespace quad
