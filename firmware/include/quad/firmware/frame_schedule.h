// The multi-rate policy of the flight loop, in one place: which of the thesis' 100 Hz stages runs in
// which iteration of a faster loop, and where a vision fix is fused.
//
// The thesis runs everything at 100 Hz (fig. 8.1). Above that rate only the attitude propagation and the
// attitude loop run in every iteration; the observer's correction, the position filter's prediction, the
// position loop and the frame-rate work (setpoint shaper, hover-bias gate, mode machine, position trim,
// landing detection) each get one iteration of the 10 ms frame, so that no iteration carries all of them
// (on the ATmega2560 at 400 Hz each iteration stays near a quarter of the 100 Hz one: docs/performance.md).
//
// A vision fix is fused where it arrives only at the thesis' rate (one iteration per frame, every stage in
// it). Above it the fusion waits for the frame-rate work's iteration and takes it over two frames (the
// filter's gate, then its update: position_filter.h), so that no period holds an iteration and a whole
// fusion (on the ATmega2560 at 200 Hz the longest flown iteration and the longest fix were 132 % of the
// period together: docs/performance.md); the application sends no telemetry or parameter in that
// iteration (FlightApp::step). The frame-rate work then runs a frame or two later over the time it missed;
// it gives way at most twice in a row, so however fast fixes come the failsafes and the landing detection
// still run in one frame of three.
#pragma once

#include <stdint.h>

#include "quad/firmware/scheduler.h"

namespace quad {
namespace fw {

// The 100 Hz stages in the order of a frame.
enum Stage : uint8_t {
  kStageCorrect = 0,       // the observer's correction
  kStagePredict = 1,       // the position filter's prediction, with the correction's rotation
  kStagePositionLoop = 2,  // eq. 8.20 to the attitude command, with the predicted state
  kStageFrameWork = 3,     // the setpoint shaper and the application's frame-rate work
  kStageCount = 4,         // from this many iterations per frame on, each stage has one of its own
};

// Spreads the stages of a frame at `rate_hz` over the iterations of a faster loop: with
// n = floor(loop_hz / rate_hz) iterations per frame, stage s runs in iteration s mod n of each frame
// (every stage in every iteration at n = 1). A loop rate that does not divide (250 Hz: frames of two and
// three iterations) runs the stages in the first n iterations of each frame.
class StageClock {
 public:
  void configure(float rate_hz, float loop_hz);
  void tick();  // once per loop iteration, before runs()
  bool runs(uint8_t stage) const { return stage % per_frame_ == index_; }
  uint8_t per_frame() const { return per_frame_; }

 private:
  RateDivider frame_;     // fires on the first iteration of each frame
  uint8_t per_frame_ = 1;
  uint8_t index_ = 0;     // the iteration within the frame (saturates)
};

// What one iteration runs, besides the attitude propagation and the attitude loop.
struct IterationPlan {
  bool correct = false;        // the observer's correction (else the gyro alone propagates)
  bool multi_rate = false;     // more than one iteration per frame: the observer's multi-rate form
  bool predict = false;        // the position filter's prediction
  bool position_loop = false;  // the position loop
  bool frame_work = false;     // the frame-rate work
  bool fix_step = false;       // a vision fix's gate or update, in the frame-rate work's place
  float correction_dt = 0.0f;  // s since the last correction (with correct)
  float frame_dt = 0.0f;       // s since the frame-rate work last ran (with frame_work)
};

// The application's background work: telemetry, the parameter and log streams, the flight log's
// definitions and its writes to the log store. It goes in what the flight stages leave of the period:
// each piece starts only when its worst case ends before the deadline (the period less a margin for the
// flight log's records, the iteration's end and the interrupts after it, and at the thesis' rate less a
// vision fix fused on arrival after the iteration), and what does not fit waits
// for a later iteration. The flight stages never wait. The costs are the ATmega2560's (docs/performance.md,
// "Background work"); the other targets run an iteration in a few percent of its period and give the
// background no deadline, so that a host preempted by its operating system sends and logs as usual.
class BackgroundBudget {
 public:
#if defined(__AVR__)
  static constexpr bool kBudgeted = true;
#else
  static constexpr bool kBudgeted = false;
#endif
  static constexpr uint16_t kTelemetryUs = 950;  // one stream's frame to both ports (14 800 cycles)
  static constexpr uint16_t kStreamUs = 720;     // a LOG_DATA (10 970 cycles) or a PARAM_VALUE
  static constexpr uint16_t kDefinitionUs = 250;  // one of the flight log's definitions (most 1 500 cycles)
  // The streams (a log download, a parameter list) wait while the flight log has more than this many
  // bytes waiting for its store: the flight's own log goes first.
  static constexpr uint16_t kStreamLogBacklog = 128;
  static constexpr uint8_t kSlowRecordsUs = 200;  // loop_timing or estimator_status and a queued fix's result, composed
  // The flight log's own records, composed (UlogFields) with their reserve in the writer's buffer: the IMU
  // topics (sensor_combined and vehicle_attitude, measured 3 700-4 300 cycles) and the frame-rate topics
  // (vehicle_local_position, the setpoint and actuator_motors). What does not fit waits for the next
  // iteration (FlightLogger::iteration).
  static constexpr uint16_t kImuRecordsUs = 300;
  static constexpr uint16_t kFrameRecordsUs = 350;
  static constexpr uint8_t kLogAppendUs = 80;    // a store append's command, and a page programmed
  static constexpr uint8_t kLogByteUs = 2;       // a byte to the store (27 cycles)
  static constexpr uint8_t kMarginEighths = 1;   // the margin, in eighths of the period
  // A vision fix fused on arrival (at the thesis' rate) shares the period with the iteration before it.
  static constexpr uint16_t kFixOnArrivalUs = 2100;  // 33 000 cycles

  // period_us: the loop's period; fuses_on_arrival: FrameSchedule::fuses_on_arrival().
  void configure(uint32_t period_us, bool fuses_on_arrival) {
    deadline_us_ = period_us - period_us / 8u * kMarginEighths;
    if (fuses_on_arrival && deadline_us_ > kFixOnArrivalUs) deadline_us_ -= kFixOnArrivalUs;
  }
  // Whether work of cost_us started elapsed_us into the iteration ends before the deadline.
  bool fits(uint32_t elapsed_us, uint32_t cost_us) const {
    return !kBudgeted || elapsed_us + cost_us <= deadline_us_;
  }
  // How many bytes the log store may take from elapsed_us on (0xFFFF: no limit).
  uint16_t log_bytes(uint32_t elapsed_us) const;

 private:
  uint32_t deadline_us_ = 0;
};

class FrameSchedule {
 public:
  // The stages at kRateHz out of a loop at loop_hz.
  static constexpr float kRateHz = 100.0f;
  // Frames in a row whose frame-rate work may give its iteration to a vision fix.
  static constexpr uint8_t kMaxFrameWorkDeferred = 2;

  void configure(float loop_hz) { stages_.configure(kRateHz, loop_hz); }

  // The next iteration, dt after the last; fix_in_progress: the filter holds a queued fix.
  IterationPlan next(float dt, bool fix_in_progress);

  // True when a fix that arrives is fused at once; false when it is queued for the frame-rate work's
  // iteration.
  bool fuses_on_arrival() const { return stages_.per_frame() == 1; }
  uint8_t iterations_per_frame() const { return stages_.per_frame(); }

 private:
  StageClock stages_;
  float correction_dt_ = 0.0f;       // s since the observer's last correction
  float frame_dt_ = 0.0f;            // s since the frame-rate work last ran
  uint8_t frame_work_deferred_ = 0;  // frames in a row whose frame-rate work gave way to a fix
};

}  // namespace fw
}  // namespace quad
