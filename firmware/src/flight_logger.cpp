#include "quad/firmware/flight_logger.h"

#include "quad/firmware/app.h"

namespace quad {
namespace fw {

namespace {

// The topics' formats (PX4's field names where PX4 has the topic), one after the other, each ended by a
// NUL, in LogTopic order. Field order is the data's byte order.
constexpr char kFormats[] QUAD_FLASH =
    "sensor_combined:uint64_t timestamp;float[3] gyro_rad;float[3] accelerometer_m_s2;float dt;uint8_t hovering;uint8_t on_ground;\0"
    "sensor_mag:uint64_t timestamp;float[3] magnetometer_ga;\0"
    "vehicle_attitude:uint64_t timestamp;float[4] q;float[3] gyro_bias;\0"
    "vehicle_local_position:uint64_t timestamp;float x;float y;float z;float vx;float vy;float vz;"
    "float[3] pos_variance;float[3] vel_variance;float[3] accel_bias;\0"
    "vision_fix:uint64_t timestamp;uint64_t timestamp_sample;float x;float y;float z;float[4] q;"
    "uint8_t result;\0"
    "vehicle_local_position_setpoint:uint64_t timestamp;float x;float y;float z;float yaw;\0"
    "actuator_motors:uint64_t timestamp;float[4] control;\0"
    "vehicle_status:uint64_t timestamp;uint8_t nav_state;uint8_t arming_state;uint8_t failsafe;\0"
    "loop_timing:uint64_t timestamp;uint32_t iterations;uint32_t overruns;uint32_t last_us;uint32_t max_us;"
    "float load;\0"
    "estimator_status:uint64_t timestamp;float vel_test_ratio;float pos_test_ratio;float hgt_test_ratio;"
    "float mag_test_ratio;float pos_horiz_accuracy;float pos_vert_accuracy;uint16_t solution_status_flags;";

// Field bytes of each topic's data (the formats above).
constexpr uint8_t kSensorCombinedBytes = 8 + 12 + 12 + 4 + 1 + 1;
constexpr uint8_t kSensorMagBytes = 8 + 12;
constexpr uint8_t kAttitudeBytes = 8 + 16 + 12;
constexpr uint8_t kLocalPositionBytes = 8 + 24 + 36;
constexpr uint8_t kVisionFixBytes = 8 + 8 + 12 + 16 + 1;
constexpr uint8_t kSetpointBytes = 8 + 16;
constexpr uint8_t kMotorsBytes = 8 + 16;
constexpr uint8_t kStatusBytes = 8 + 3;
constexpr uint8_t kLoopTimingBytes = 8 + 16 + 4;
constexpr uint8_t kEstimatorStatusBytes = 8 + 24 + 2;
// A frame-rate iteration's records, queued together and stored in one append (FlightLogger::iteration).
static_assert(ulog::data_record_bytes(kSensorCombinedBytes) + ulog::data_record_bytes(kAttitudeBytes) +
                      ulog::data_record_bytes(kSensorMagBytes) + ulog::data_record_bytes(kLocalPositionBytes) +
                      ulog::data_record_bytes(kSetpointBytes) + ulog::data_record_bytes(kMotorsBytes) <=
                  UlogWriter::kStagingBytes,
              "an iteration's records must fit the writer's buffer");

#if defined(__AVR__)
#define QUAD_LOG_HW "apm25"
#elif defined(__arm__)
#define QUAD_LOG_HW "mps2-an386"
#else
#define QUAD_LOG_HW "host"
#endif
#if !defined(QUAD_GIT_HASH)
#define QUAD_GIT_HASH ""
#endif

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

namespace {

// Where a topic's format starts in kFormats and its length, counted by the compiler: walking the texts
// in flash from the start for each format and subscription record costs the AVR thousands of cycles in
// the header's armed iterations (docs/logging.md, "Cost on the ATmega2560").
struct FormatSpan {
  uint16_t offset;
  uint16_t length;
};

constexpr FormatSpan format_span(uint8_t topic) {
  uint16_t at = 0;
  for (uint8_t i = 0; i < topic; ++i) {
    while (kFormats[at] != '\0') ++at;
    ++at;
  }
  uint16_t n = 0;
  while (kFormats[at + n] != '\0') ++n;
  return FormatSpan{at, n};
}

constexpr FormatSpan kFormatSpans[kLogTopicCount] QUAD_FLASH = {
    format_span(0), format_span(1), format_span(2), format_span(3), format_span(4),
    format_span(5), format_span(6), format_span(7), format_span(8), format_span(9)};
static_assert(kLogTopicCount == 10, "one span per topic");

FormatSpan log_topic_span(uint8_t topic) {
  FormatSpan span;
  flash_copy(&span, &kFormatSpans[topic], sizeof span);
  return span;
}

}  // namespace

FlashText log_topic_format(uint8_t topic) { return FlashText{kFormats + log_topic_span(topic).offset}; }

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
  max_us_ = 0;
  overruns_seen_ = app.loop_timer().overruns();
  dropped_seen_ = writer_.dropped();
  // The definitions follow in the iterations (iteration()): an arming between iterations or in the mode
  // machine leaves them to the background of the next ones.
}

void FlightLogger::write_definitions(const FlightApp& app) {
  // On the ground no iteration has a deadline to keep: a log opened at boot gets its definitions in its
  // first iteration, so that its data starts with the first IMU sample (the replay needs the boot
  // calibration's samples).
  const bool armed = app.armed();
  const uint16_t budget = armed ? kHeaderBytesPerIteration : 0xFFFFu;
  const BackgroundBudget& background = app.background();
  uint16_t bytes = 0;
  while (phase_ != kPhaseData && bytes < budget &&
         (!armed || background.fits(app.iteration_elapsed_us(), BackgroundBudget::kDefinitionUs)) && writer_.flush()) {
    if (!next_definition(app, &bytes)) {
      phase_ = kPhaseData;
      write_status(app);
    }
  }
}

bool FlightLogger::next_definition(const FlightApp& app, uint16_t* bytes) {
  switch (phase_) {
    case kPhaseFormats: {
      const FormatSpan span = log_topic_span(item_);
      writer_.format(FlashText{kFormats + span.offset}, span.length);
      *bytes = static_cast<uint16_t>(*bytes + span.length);
      if (++item_ == kLogTopicCount) phase_ = kPhaseInfo, item_ = 0;
      return true;
    }
    case kPhaseInfo:
      switch (item_++) {
        case 0: writer_.info(QUAD_TEXT("sys_name"), QUAD_TEXT("quad-stereo")); break;
        case 1: writer_.info(QUAD_TEXT("ver_hw"), QUAD_TEXT(QUAD_LOG_HW)); break;
        case 2: if (QUAD_GIT_HASH[0] != '\0') writer_.info(QUAD_TEXT("ver_sw"), QUAD_TEXT(QUAD_GIT_HASH)); break;
        default:
          writer_.info(QUAD_TEXT("loop_hz"), static_cast<uint32_t>(app.params().get(kLoopHz) + 0.5f));
          phase_ = kPhaseParams, item_ = 0;
          break;
      }
      *bytes = static_cast<uint16_t>(*bytes + 32);
      return true;
    case kPhaseParams: {
      const ParamInfo info = param_info(item_);
      writer_.parameter(info.name, app.params().get(item_));
      *bytes = static_cast<uint16_t>(*bytes + 30);
      if (++item_ == kParamCount) phase_ = kPhaseSubscriptions, item_ = 0;
      return true;
    }
    case kPhaseSubscriptions:
      if (item_ == kLogTopicCount) return false;
      writer_.add_logged(item_, log_topic_format(item_));
      ++item_;
      *bytes = static_cast<uint16_t>(*bytes + 30);
      return true;
    case kPhaseData:
      break;
  }
  return false;
}

void FlightLogger::iteration(const FlightApp& app, const IterationPlan& plan, const hal::ImuSample& imu,
                             const hal::MagSample* mag, float dt, bool hovering, bool on_ground) {
  if (mode_ == LogMode::kBoot && !boot_log_started_) {
    boot_log_started_ = true;
    start(app);
  }
  const uint32_t t = app.now_us();
  count_clock(t);
  if (timing_rate_.tick()) timing_due_ = true;
  if (estimator_rate_.tick()) estimator_due_ = true;
  if (!writer_.is_open()) return;
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
  // A full buffer makes room in the store only as far as the iteration has time (else the record is
  // dropped and counted): the records are composed after the iteration's flight stages.
  writer_.set_room_flush_limit(app.background().log_bytes(app.iteration_elapsed_us()));
  if (++imu_count_ >= imu_div_) {
    imu_count_ = 0;
    write_imu_topics(app, now, imu, dt, hovering, on_ground);
  }
  if (mag != nullptr) {
    uint8_t* p = writer_.begin_data(kLogSensorMag, kSensorMagBytes);
    if (p != nullptr) {
      UlogFields(p).u64(now).f32(&mag->field.x, 3);
    }
  }
  if (plan.frame_work) write_frame_topics(app, now);
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
      .f32(static_cast<float>(loop.load_permille()) * 1e-3f);
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
