// The flight log: one ULog (ulog_writer.h) per flight in the target's LogStore, with the topics of
// docs/logging.md.
//
// LOG_MODE 1 opens a log when the vehicle arms and closes it when it disarms; 2 opens one at the first
// iteration after boot and keeps it to the end; 0 logs nothing. The definitions (formats, information,
// every parameter, the subscriptions) are written over the first iterations of a log, at most
// kHeaderBytesPerIteration each and in the time the iteration has left while armed (BackgroundBudget),
// so that no flight iteration carries all of them (on the ground, all at once); the data starts when they are complete, with a vehicle_status record. Lines (STATUSTEXT) sent before that are not in the log.
//
// What an iteration writes, and where (frame_schedule.h):
//   every LOG_IMU_DIV-th iteration   sensor_combined, vehicle_attitude
//   with a magnetometer sample       sensor_mag
//   the frame-rate work's iteration  vehicle_local_position, actuator_motors, the setpoint (armed)
//   an iteration with no fix step and no frame-rate work of a faster loop: the definitions, and
//                                    loop_timing (once a second, and after an overrun) or else
//                                    estimator_status (at kEstimatorStatusHz)
// On the ATmega2560 above the thesis' rate the IMU and frame-rate topics are composed only when the
// iteration has time for them (BackgroundBudget::kImuRecordsUs, kFrameRecordsUs); otherwise they go in the
// next iteration with time,
// with that iteration's sample and state: the IMU topics then skip one sample and take the next, one in
// LOG_IMU_DIV on average (at LOG_IMU_DIV 1 the skipped sample is lost and counted as a drop, so a dropout
// message follows), and frame-rate topics still waiting when the next frame-rate work comes are counted
// as a drop. loop_timing's records_deferred counts the records composed late.
// Events between iterations queue their records at once: vision fixes, mode changes (vehicle_status),
// STATUSTEXT lines (logged strings), parameter changes. An iteration's data records and those queued
// since the last one go to the store in one append at its end, as many bytes as the iteration has time
// for (BackgroundBudget); the rest waits in the writer's buffer for the next iterations.
#pragma once

#include <stdint.h>

#include "quad/estimation/position_filter.h"
#include "quad/firmware/frame_schedule.h"
#include "quad/firmware/log_store.h"
#include "quad/firmware/modes.h"
#include "quad/firmware/params.h"
#include "quad/firmware/scheduler.h"
#include "quad/firmware/ulog_writer.h"
#include "quad/hal/hal.h"
#include "quad/link/messages.h"
#include "quad/math/math.h"

namespace quad {
namespace fw {

class FlightApp;

// The topics, in the order of their msg_id (docs/logging.md).
enum LogTopic : uint8_t {
  kLogSensorCombined,
  kLogSensorMag,
  kLogVehicleAttitude,
  kLogLocalPosition,
  kLogVisionFix,
  kLogSetpoint,
  kLogActuatorMotors,
  kLogVehicleStatus,
  kLogLoopTiming,
  kLogEstimatorStatus,
  kLogTopicCount,
};

// vision_fix.result
enum class LogFixResult : uint8_t {
  kFused = 0,
  kRejectedGate = 1,
  kRejectedOld = 2,  // too old, out of order, no attitude at the capture time, or another fix in progress
  kInvalid = 3,
  kReset = 4,        // the filter reset to it
  kQueued = 5,       // the result follows in a later record
};

// The vision_fix result of what the filter did with a fix (reset: the filter reset to it).
LogFixResult log_fix_result(est::FixResult r, bool reset);

enum class LogMode : uint8_t { kOff = 0, kArmed = 1, kBoot = 2 };

class FlightLogger {
 public:
  // estimator_status records a second (the health report's ESTIMATOR_STATUS fields).
  static constexpr float kEstimatorStatusHz = 5.0f;
  // Definition bytes queued per armed iteration at most (a format's text goes whole, up to 190 bytes),
  // and on the ATmega2560 only while the iteration has time for another (BackgroundBudget).
  static constexpr uint16_t kHeaderBytesPerIteration = 512;

  // store: the target's log storage, or null (nothing is logged).
  void init(const LogStore* store) { writer_.attach(store); }
  void configure(const Params& p, float loop_hz);

  // One control iteration of the application, after its control step (FlightApp::step).
  // hovering, on_ground: what the estimator was told this iteration (they gate the hover-bias tracker and
  // the ground hold; the replay needs them).
  void iteration(const FlightApp& app, const IterationPlan& plan, const hal::ImuSample& imu,
                 const hal::MagSample* mag, float dt, bool hovering, bool on_ground);
  // A mode change or a refused command (FlightApp::report_transition): opens or closes the log, and
  // records the state.
  void transition(const FlightApp& app, const Transition& t);
  void statustext(uint32_t now_us, const mavlink::Statustext& msg);
  void param_changed(uint8_t index, float value);
  // A vision fix at arrival (now_us): the fix as a NED position (null: refused before its conversion),
  // when it was taken, the star's attitude (null, or all zero: none) and what became of it.
  void vision_fix(uint32_t now_us, const Vec3* p_ned, uint32_t capture_us, const float* q, LogFixResult result);
  // What became of the queued fix (kQueued earlier) in a fix step: recorded in the next iteration with
  // room (kQueued: not finished yet, nothing to record).
  void vision_fix_result(LogFixResult result) {
    if (result != LogFixResult::kQueued) queued_result_ = static_cast<uint8_t>(result);
  }
  // Closes an open log (the host firmware at exit).
  void stop() { writer_.close(); }

  bool logging() const { return writer_.is_open(); }
  bool header_done() const { return writer_.is_open() && phase_ == kPhaseData; }
  uint16_t logs_opened() const { return logs_opened_; }
  uint32_t dropped() const { return writer_.dropped(); }
  // The time (BackgroundBudget) the records due in the coming iteration() of `plan` take to compose, above
  // the thesis' rate (iteration()); 0 when no log is recording data. The background work before the
  // flight log leaves it.
  uint16_t records_due_us(const IterationPlan& plan) const {
    if (!header_done() || !plan.multi_rate) return 0;
    uint16_t us = (plan.frame_work || frame_due_) ? BackgroundBudget::kFrameRecordsUs : 0;
    if (imu_count_ + 1 >= imu_div_) us = static_cast<uint16_t>(us + BackgroundBudget::kImuRecordsUs);
    return us;
  }
  // Records composed in a later iteration than theirs for want of time (loop_timing records_deferred).
  uint16_t records_deferred() const { return records_deferred_; }
  // Bytes waiting for the store.
  uint16_t backlog() const { return writer_.pending(); }
  LogMode mode() const { return mode_; }

 private:
  enum Phase : uint8_t { kPhaseFormats, kPhaseInfo, kPhaseParams, kPhaseSubscriptions, kPhaseData };

  void start(const FlightApp& app);
  // Queues the next definitions while the store takes them, up to the iteration's budget.
  void write_definitions(const FlightApp& app);
  // One definition record; false when the definitions are complete.
  bool next_definition(const FlightApp& app, uint16_t* bytes);
  void write_status(const FlightApp& app);
  void write_loop_timing(const FlightApp& app);
  void write_estimator_status(const FlightApp& app);
  // now: this iteration's stamp().
  void write_frame_topics(const FlightApp& app, uint64_t now);
  // The IMU, magnetometer and frame-rate topics of the iteration, each when it has time for them.
  void write_topics(const FlightApp& app, const IterationPlan& plan, uint64_t now, const hal::ImuSample& imu,
                    const hal::MagSample* mag, float dt, bool hovering, bool on_ground);
  void write_imu_topics(const FlightApp& app, uint64_t now, const hal::ImuSample& imu, float dt, bool hovering,
                        bool on_ground);
  // The vehicle clock on 64 bits (the 32-bit microsecond clock wraps after 71 minutes).
  uint64_t stamp(uint32_t now_us);
  // Counts the wraps of the 32-bit clock (every iteration, logging or not).
  void count_clock(uint32_t now_us);
  // Records were dropped since the last dropout message: writes one when there is room.
  void note_dropout(uint32_t now_us);

  UlogWriter writer_;
  LogMode mode_ = LogMode::kArmed;
  uint8_t imu_div_ = 1;
  uint8_t imu_count_ = 0;
  Phase phase_ = kPhaseFormats;
  uint8_t item_ = 0;           // the definition within the phase
  uint8_t last_reason_ = 0;    // Reason of the last transition
  bool boot_log_started_ = false;
  bool timing_due_ = false;
  bool estimator_due_ = false;
  bool frame_due_ = false;     // the frame-rate topics wait for an iteration with time for them
  uint16_t records_deferred_ = 0;
  RateDivider timing_rate_;
  RateDivider estimator_rate_;
  uint32_t overruns_seen_ = 0;
  uint32_t dropped_seen_ = 0;     // writer_.dropped() at the last dropout message
  uint32_t dropout_start_us_ = 0;  // the first iteration that saw the records lost
  bool in_dropout_ = false;
  uint32_t max_us_ = 0;        // the longest iteration of this log
  uint32_t clock_high_ = 0;    // stamp(): the wraps of the 32-bit clock
  uint32_t clock_last_ = 0;
  uint16_t logs_opened_ = 0;
  Vec3 queued_fix_;            // the fix queued for the filter (kQueued), for its result's record
  uint32_t queued_capture_us_ = 0;
  uint8_t queued_result_ = kNoResult;  // the queued fix's result, waiting for an iteration with room
  static constexpr uint8_t kNoResult = 0xFF;
};

// The topics' formats, one NUL-terminated text per topic in LogTopic order (docs/logging.md).
FlashText log_topic_format(uint8_t topic);

}  // namespace fw
}  // namespace quad
