// The flight application: everything between the sensors and the motors, composed of four parts with one
// job each, and the glue between them.
//
//   FrameSchedule   which of the 100 Hz stages this iteration runs (frame_schedule.h)
//   StateEstimator  calibration, clip guard, observer, position filter, fix fusion (state_estimator.h)
//   FlightControl   modes and failsafes, setpoints, trim, cascade, mixer, landing (flight_control.h)
//   GroundLink      MAVLink on both ports: parsers, signing, parameters, commands (ground_link.h),
//                   with the telemetry streams (telemetry.h)
//   FlightLogger    the flight's ULog in the target's log store (flight_logger.h)
//
// It references no HAL symbol. A per-target runner owns the loop: it hands the application the bytes each
// serial port received (receive()) and, on boards with sensors, each IMU sample (step()); the application
// writes its frames through AppIo::write and leaves its motor commands in motors(). In hardware-in-the-loop
// the HIL runner's bridge (hil_bridge.h) turns HIL_SENSOR into step() and answers with the motors.
//
// One control iteration (thesis fig. 8.1; FlightApp::step):
//   frame schedule -> estimator (calibration until the vehicle was still for CAL_TIME, then the observer,
//   the attitude history and the Kalman prediction with u = g e_z + R a_B, eq. 8.7) -> mode machine and
//   failsafes -> control (position / manual / landing, eq. 8.20-8.40, mixer) -> landing detection ->
//   one telemetry stream or one streamed parameter (none beside a fix step).
// Vision fixes are fused at their capture time (eq. 8.5 with the errata sign), where they arrive at 100 Hz
// or, faster, over the next two frames (frame_schedule.h).
#pragma once

#include <stdint.h>

#include "quad/firmware/flight_control.h"
#include "quad/firmware/flight_logger.h"
#include "quad/firmware/frame_schedule.h"
#include "quad/firmware/ground_link.h"
#include "quad/firmware/params.h"
#include "quad/firmware/scheduler.h"
#include "quad/firmware/state_estimator.h"
#include "quad/firmware/telemetry.h"
#include "quad/hal/hal.h"
#include "quad/link/mavlink.h"

namespace quad {
namespace fw {

struct AppIo {
  // Parameter storage (hal::storage_read/write on a board).
  StorageIo storage;
  // Queues bytes on a serial port (hal::serial_write); frames that do not fit are dropped.
  uint16_t (*write)(uint8_t port, const uint8_t* data, uint16_t length);
  // Free-running microsecond clock used only to measure the execution time of an iteration.
  uint32_t (*micros)();
  // Optional: every STATUSTEXT line also goes here (the host prints it on stderr); null on a board.
  void (*console)(uint8_t severity, const char* text, uint8_t length) = nullptr;
  // Optional: marks the phases of an iteration for a profiler (hal::trace on a board).
  void (*trace)(hal::TracePoint point) = nullptr;
  // Optional: the flight logs (a target's LogStore: log_store.h), written by the flight log and served by
  // the log protocol; null: no logs (nothing written, LOG_ENTRY num_logs 0).
  const LogStore* log_store = nullptr;
  // Optional: bytes a port's transmit queue takes now (hal::serial_tx_free); null: as many as offered.
  uint16_t (*tx_free)(uint8_t port) = nullptr;
  // Hardware-in-the-loop: HIL_SENSOR frames go to this hook (HilBridge::connect sets it); null on a board,
  // whose sensors come from its drivers.
  void (*hil_sensor)(void* context, const mavlink::Frame& frame) = nullptr;
  void* hil_context = nullptr;
};

// Counters reported in SYS_STATUS and used by the tests.
struct AppCounters {
  uint32_t iterations = 0;
  uint32_t fixes_received = 0;
  uint32_t fixes_fused = 0;
  uint32_t fixes_rejected = 0;  // by the filter (gate, too old, out of order) or no attitude at capture
  uint32_t fixes_invalid = 0;   // wrong frame, position_valid 0, non-finite
  uint32_t tx_dropped_bytes = 0;  // bytes the ports did not take
  uint32_t commands = 0;
  uint32_t imu_clipped_samples = 0;  // samples with an accel or gyro axis at full scale (imu_clip.h)
  uint32_t imu_clip_bursts = 0;      // runs of them, one STATUSTEXT each
};

class FlightApp {
 public:
  // Loads the parameters (defaults and a STATUSTEXT when the store is bad) and configures every part.
  void init(const AppIo& io);

  // Sets a parameter for this run without storing it (the host's --params file). Returns nullptr when
  // taken, else why not.
  const char* override_param(uint8_t index, float value);

  // Bytes received on a port at vehicle time now_us (board clock; ignored in HIL, where the simulator's
  // clock rules).
  void receive(uint8_t port, const uint8_t* data, uint16_t length, uint32_t now_us);

  // One control iteration with a sample taken at t_us (board mode; in HIL the bridge calls hil_step()).
  void step(uint32_t t_us, const hal::ImuSample& imu, const hal::MagSample* mag);
  // The same on the simulator's 64-bit clock (TIMESYNC answers with it).
  void hil_step(uint64_t time_usec, const hal::ImuSample& imu, const hal::MagSample* mag) {
    hil_time_usec_ = time_usec;
    step(static_cast<uint32_t>(time_usec), imu, mag);
  }

  // An RC frame from the receiver (board mode; in HIL MANUAL_CONTROL arrives through receive()). With
  // RC_SWITCHES set, the two toggle switches of thesis sec. 6.1.4 act on their transitions: motor enable
  // on -> arm, off -> disarm at once (the kill switch); auto on -> AUTO, off -> MANUAL.
  void rc_input(const ctrl::RcSticks& sticks, uint32_t t_us, const RcSwitches* switches = nullptr);

  // Motor commands of the last iteration, 0..1 each, all 0 when disarmed.
  const float (&motors() const)[hal::kMotorCount] { return control_.motors(); }

  FlightMode mode() const { return control_.mode(); }
  bool armed() const { return control_.armed(); }
  bool hil() const { return hil_sensor_ != nullptr; }
  // Status LED: fast blink while calibrating, slow blink when ready, steady when armed.
  bool led(uint32_t now_us) const;
  bool calibrated() const { return estimator_.calibrated(); }
  const Params& params() const { return params_; }
  StoreStatus store_status() const { return store_status_; }
  AppCounters counters() const;
  uint32_t fixes_rejected() const { return fixes_rejected_; }
  const LoopTimer& loop_timer() const { return loop_timer_; }
  LoopTimer& loop_timer() { return loop_timer_; }
  // The iteration's time so far, on the firmware's own clock, and what its background work may take.
  // Read only where the background has a deadline (BackgroundBudget::kBudgeted): elsewhere 0, and the
  // clock is read twice an iteration as the loop timer reads it.
  uint32_t iteration_elapsed_us() const {
    return BackgroundBudget::kBudgeted ? loop_timer_.elapsed_us(micros_()) : 0u;
  }
  const BackgroundBudget& background() const { return background_; }
  const StateEstimator& estimator() const { return estimator_; }
  const FlightControl& control() const { return control_; }
  const FlightLogger& logger() const { return logger_; }
  // Closes the open flight log (the host firmware at exit).
  void close_log() { logger_.stop(); }
  GroundLink& link() { return link_; }
  const GroundLink& link() const { return link_; }
  Vec3 position() const { return estimator_.position(); }
  Vec3 velocity() const { return estimator_.velocity(); }
  Quat attitude() const { return estimator_.attitude(); }
  uint32_t filter_resets() const { return estimator_.filter_resets(); }
  Vec3 accel_bias() const { return estimator_.accel_bias(); }
  float hover_trim() const { return control_.hover_trim(); }
  Vec3 position_trim() const { return control_.position_trim(); }
  const mavlink::Parser& parser(uint8_t port) const { return link_.parser(port); }
  const RadioSigning& radio_signing() const { return link_.radio_signing(); }
  uint32_t now_us() const { return now_us_; }
  // What the mode machine and SYS_STATUS see of the vehicle. with_throttle false leaves rc_throttle at 0:
  // only commands read it (ModeMachine::update() does not), and its conversion costs the AVR a division.
  ModeInputs mode_inputs(bool with_throttle = true) const;

  // The ground link's handler (ground_link.h).
  void hil_frame(const mavlink::Frame& frame);
  // Arming waits for the estimator's pre-arm check (StateEstimator::preflight(): its variances).
  Transition mode_command(Command c);
  void report_transition(const Transition& t);
  void position_target(const Vec3& target, const float* yaw);
  void star_fix(const mavlink::LandingTarget& msg);
  void star_covariance(const mavlink::LandingTargetCovariance& msg);
  void external_pose(const ExternalPose& pose);
  ParamUpdate set_param(uint8_t index, float value);
  uint64_t timesync_us() const { return hil() ? hil_time_usec_ : now_us_; }
  // An iteration has run; hil_time_usec(): the simulator's time of the last one.
  bool stepped() const { return clock_started_; }
  uint64_t hil_time_usec() const { return hil_time_usec_; }

 private:
  // Configures every part from p; false (and nothing changed) when a part refuses it, with the name of
  // the offending field in *error.
  bool apply_params(const Params& p, const char** error);
  // A STATUSTEXT the first time an iteration in flight takes longer than the period.
  void report_overrun();
  // Tells the operator what the estimator reported.
  void report(EstimatorEvent event);
  // One step of the fusion (the whole of it at 100 Hz, else a gate or an update), traced, with its
  // result counted once it is final.
  template <class Step>
  LogFixResult fix_step(Step step);
  // A fix as a NED position at its capture time: fused, queued, or refused; q: the star's attitude
  // (LANDING_TARGET.q) for the log, or null.
  void position_fix_at(const Vec3& p_ned, uint32_t capture_us, const float* q);
  // A LANDING_TARGET for the EKF: queued with its body-frame star and attitude, logged.
  void star_fix_ekf(const mavlink::LandingTarget& msg, uint32_t capture_us);
  // Every STATUSTEXT line, for the flight log (GroundLink::Io::statustext; context: the application).
  static void log_statustext(void* app, const mavlink::Statustext& msg);
  // Counters, freshness and the jump report for a fix the filter finished with (reset: it reset to it).
  void fix_result(est::FixResult r, bool reset);
  void mark(hal::TracePoint point) const {
    if (trace_ != nullptr) trace_(point);
  }

  // The hooks of AppIo the application calls itself; the ground link keeps the storage, write and
  // console ones (one copy of each in SRAM).
  uint32_t (*micros_)() = nullptr;
  void (*trace_)(hal::TracePoint point) = nullptr;
  void (*hil_sensor_)(void* context, const mavlink::Frame& frame) = nullptr;
  void* hil_context_ = nullptr;
  Params params_;
  StoreStatus store_status_ = StoreStatus::kEmpty;
  LoopTimer loop_timer_;
  FrameSchedule schedule_;
  BackgroundBudget background_;
  StateEstimator estimator_;
  FlightControl control_;
  GroundLink link_;
  Telemetry telemetry_;
  FlightLogger logger_;
  RcSwitchEdges switch_edges_;

  uint32_t now_us_ = 0;        // vehicle time: the last step, or (on a board) the last receive()
  uint32_t last_step_us_ = 0;  // time of the last control iteration, for its period
  uint64_t hil_time_usec_ = 0;
  bool clock_started_ = false;
  bool vision_seen_ = false;
  bool overrun_reported_ = false;  // in this flight (cleared while disarmed)
  uint32_t vision_time_us_ = 0;   // when the last fix was taken, on the vehicle clock
  uint8_t fixes_rejected_in_a_row_ = 0;  // vision fixes the filter refused since it last took one
  uint32_t fixes_received_ = 0;
  uint32_t fixes_fused_ = 0;
  uint32_t fixes_rejected_ = 0;
  uint32_t fixes_invalid_ = 0;
};

}  // namespace fw
}  // namespace quad
