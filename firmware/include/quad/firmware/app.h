// The flight application: everything between the sensors and the motors, and the MAVLink link to
// the simulator, the ground station and the vision station.
//
// It references no HAL symbol. A per-target runner owns the loop: it hands the application the bytes
// each serial port received (receive()) and, on boards with sensors, each IMU sample (step()); the
// application writes its frames through AppIo::write and leaves its motor commands in motors(). In HIL
// the sample arrives as HIL_SENSOR inside receive(): the application then runs one iteration on the
// simulator's clock and answers with HIL_ACTUATOR_CONTROLS (docs/hil-protocol.md).
//
// One control iteration (thesis fig. 8.1):
//   boot calibration (until the vehicle was still for CAL_TIME) ->
//   conditioned observer (attitude, gyro bias; thesis ch. 4) -> attitude history (vision delay) ->
//   Kalman predict with u = g e_z + R a_B (thesis eq. 8.7, at ~100 Hz) ->
//   flight-mode machine and failsafes -> position / manual / landing control (thesis eq. 8.20-8.40) ->
//   motor commands -> telemetry.
// Vision fixes are fused when they arrive, at their capture time (eq. 8.5 with the errata sign).
#pragma once

#include <stdint.h>

#include "quad/control/cascade.h"
#include "quad/control/manual.h"
#include "quad/control/setpoint_shaper.h"
#include "quad/estimation/conditioned_observer.h"
#include "quad/estimation/hover_accel_bias.h"
#include "quad/estimation/position_filter.h"
#include "quad/firmware/calibration.h"
#include "quad/firmware/position_trim.h"
#include "quad/firmware/imu_clip.h"
#include "quad/firmware/modes.h"
#include "quad/firmware/params.h"
#include "quad/firmware/radio_signing.h"
#include "quad/firmware/scheduler.h"
#include "quad/firmware/vision.h"
#include "quad/hal/hal.h"
#include "quad/link/mavlink.h"

namespace quad {
namespace fw {

// System and component ids (docs/hil-protocol.md).
constexpr uint8_t kVehicleSystemId = 1;
constexpr uint8_t kVehicleComponentId = 1;

// The position filter predicts, the observer corrects and the position loop runs at about this rate
// whatever the control loop rate (the thesis' 100 Hz); only the attitude propagation and the attitude
// loop run at the loop rate. The filter's history covers 250 ms of vision delay at that rate.
constexpr float kPositionRateHz = 100.0f;
constexpr int kPositionHistory = est::history_length(100);

// MAVLink's MAV_CMD_COMPONENT_ARM_DISARM param2 that forces a disarm in flight.
constexpr float kForceDisarmMagic = 21196.0f;

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
};

// The toggle switches of the RC transmitter (thesis sec. 6.1.4: 1000 or 2000 us).
struct RcSwitches {
  bool motors_enabled = false;
  bool auto_mode = false;
};

// Counters reported in SYS_STATUS and used by the tests. All zero at construction: one clear of the
// whole record (out of line in app.cpp) rather than ten 32-bit zero stores inlined into FlightApp().
struct AppCounters {
  AppCounters();

  uint32_t iterations;
  uint32_t hil_sensor_frames;
  uint32_t fixes_received;
  uint32_t fixes_fused;
  uint32_t fixes_rejected;   // by the filter (gate, too old, out of order) or no attitude at capture
  uint32_t fixes_invalid;    // wrong frame, position_valid 0, non-finite
  uint32_t tx_dropped_bytes; // bytes the ports did not take
  uint32_t commands;
  uint32_t imu_clipped_samples;  // samples with an accel or gyro axis at full scale (imu_clip.h)
  uint32_t imu_clip_bursts;      // runs of them, one STATUSTEXT each
};

class FlightApp {
 public:
  FlightApp();

  // Loads the parameters (defaults and a STATUSTEXT when the store is bad) and configures everything.
  // hil: sensors come from HIL_SENSOR and the motor commands go out as HIL_ACTUATOR_CONTROLS.
  void init(const AppIo& io, bool hil);

  // Sets a parameter for this run without storing it (the host's --params file). Returns nullptr when
  // taken, else why not.
  const char* override_param(uint8_t index, float value);

  // Bytes received on a port at vehicle time now_us (board clock; ignored in HIL, where the simulator's
  // clock rules).
  void receive(uint8_t port, const uint8_t* data, uint16_t length, uint32_t now_us);

  // One control iteration with a sample taken at t_us (board mode; HIL calls it from HIL_SENSOR).
  void step(uint32_t t_us, const hal::ImuSample& imu, const hal::MagSample* mag);

  // An RC frame from the receiver (board mode; in HIL MANUAL_CONTROL arrives through receive()). With
  // RC_SWITCHES set, the two toggle switches of thesis sec. 6.1.4 act on their transitions: motor enable
  // on -> arm, off -> disarm at once (the kill switch); auto on -> AUTO, off -> MANUAL.
  void rc_input(const ctrl::RcSticks& sticks, uint32_t t_us, const RcSwitches* switches = nullptr);

  // Motor commands of the last iteration, 0..1 each, all 0 when disarmed.
  const float (&motors() const)[hal::kMotorCount] { return motors_; }

  FlightMode mode() const { return modes_.mode(); }
  // Status LED: fast blink while calibrating, slow blink when ready, steady when armed.
  bool led(uint32_t now_us) const;
  bool calibrated() const { return calibration_.done(); }
  const Params& params() const { return params_; }
  StoreStatus store_status() const { return store_status_; }
  const AppCounters& counters() const { return counters_; }
  const LoopTimer& loop_timer() const { return loop_timer_; }
  LoopTimer& loop_timer() { return loop_timer_; }
  Vec3 position() const { return filter_.position(); }
  uint32_t filter_resets() const { return filter_.health().resets; }
  Vec3 accel_bias() const { return accel_bias_.bias(); }
  float hover_trim() const { return trim_.accel_z(); }
  Vec3 position_trim() const { return trim_.accel(); }
  Vec3 velocity() const { return filter_.velocity(); }
  Quat attitude() const { return observer_.attitude(); }
  const mavlink::Parser& parser(uint8_t port) const { return parsers_[port]; }
  const RadioSigning& radio_signing() const { return radio_; }
  uint32_t now_us() const { return now_us_; }

 private:
  // Configuration from the parameters; false (and nothing changed) when a component refuses them, with
  // the name of the offending field in *error.
  bool apply_params(const Params& candidate, const char** error);

  void on_frame(uint8_t port, const mavlink::Frame& frame);
  void on_hil_sensor(const mavlink::HilSensor& msg);
  void on_command(uint8_t port, const mavlink::CommandLong& cmd);
  void on_param_set(uint8_t port, const mavlink::ParamSet& msg);
  void on_param_read(uint8_t port, const mavlink::ParamRequestRead& msg);
  void on_setpoint(const mavlink::SetPositionTargetLocalNed& msg);
  void on_manual_control(const mavlink::ManualControl& msg);
  void on_fix(const Vec3& p_ned, uint32_t capture_us);
  // One step of the filter's fusion (the whole of it, or a gate or an update at 400 Hz), traced, with
  // its result counted once it is final.
  template <class Step>
  void fix_step(Step step);
  // Counters, freshness and the jump report for a fix the filter finished with (reset: it reset to it).
  void fix_result(est::FixResult r, bool reset);
  void on_timesync(uint8_t port, const mavlink::Timesync& msg);
  void on_setup_signing(uint8_t port, const SetupSigning& msg);

  void calibrate(const hal::ImuSample& imu, const hal::MagSample* mag);
  bool hovering() const;
  // accel_valid false: the accelerometer clipped (no gravity correction, the held kinematic acceleration).
  void estimate(const Vec3& gyro, const Vec3& accel, bool accel_valid, const hal::MagSample* mag, float dt);
  // Clip counters, SYS_STATUS flags and the once-per-burst STATUSTEXT after a guarded sample.
  void report_clipping();
  // with_throttle false leaves rc_throttle at 0: ModeMachine::update() does not read it (commands do).
  ModeInputs mode_inputs(bool with_throttle = true) const;
  void handle_transition(const Transition& t);
  void enter_mode(FlightMode from, FlightMode to);
  // slow_now: this iteration runs the frame-rate work (slow_dt: the time since it last did).
  void control(float dt, bool slow_now, float slow_dt);
  void detect_landing(float dt);
  void telemetry();
  void mark(hal::TracePoint point) const {
    if (io_.trace != nullptr) io_.trace(point);
  }

  void send_statustext(uint8_t severity, FlashText text);
  void send_statustext(const mavlink::Statustext& msg);
  void send_param(uint8_t port, uint8_t index);
  void send_ack(uint8_t port, uint16_t command, uint8_t result);
  void send_actuators(uint64_t time_usec);
  uint8_t base_mode() const;
  template <class Msg>
  void send(uint8_t port, const Msg& msg);
  // Finishes (and on the radio signs) a frame whose payload send() wrote into `buffer`, and queues it.
  void transmit(uint8_t port, uint32_t message_id, uint8_t crc_extra, uint8_t full_length, uint8_t* buffer);
  template <class Msg>
  void broadcast(const Msg& msg);

  AppIo io_{};
  bool hil_ = false;
  Params params_;
  StoreStatus store_status_ = StoreStatus::kEmpty;

  // Parsers that also know SETUP_SIGNING (so the radio's can refuse it explicitly).
  struct FirmwareParser : mavlink::Parser {
    FirmwareParser() : mavlink::Parser(firmware_message_info) {}
  };
  FirmwareParser parsers_[hal::kPortCount];
  RadioSigning radio_;
  uint32_t radio_rejected_reported_ = 0;
  mavlink::Sender senders_[hal::kPortCount];

  LoopTimer loop_timer_;
  // The stages that run at kPositionRateHz out of a faster loop, each in its own iteration of the 10 ms
  // frame (at 100 Hz all in every one): the observer's correction, the position filter's prediction
  // (after it, with its rotation), the position loop (after that, with the predicted state), the
  // setpoint shaper. The attitude propagation and the attitude loop run in every iteration.
  StageClock stages_;
  float correction_dt_ = 0.0f;     // s since the observer's last correction
  float slow_dt_ = 0.0f;           // s since the frame-rate work (shaper included) last ran
  uint8_t frame_work_deferred_ = 0;  // frames in a row whose frame-rate work gave way to a vision fix
  FlightMode outer_mode_ = FlightMode::kDisarmed;  // the mode of the last control(): a new one runs the position loop at once
  RateDivider heartbeat_rate_;
  RateDivider attitude_rate_;
  RateDivider position_tel_rate_;
  RateDivider status_rate_;

  BootCalibration calibration_;
  CalibrationResult bias_;
  est::ConditionedObserver observer_;
  est::PositionFilter<kPositionHistory> filter_;
  AttitudeHistory history_;
  Vec3 accel_sum_;       // body specific force summed between position-filter predictions (valid samples)
  Vec3 pending_mag_;     // a magnetometer sample that arrived between two corrections
  bool mag_pending_ = false;
  ImuClipGuard imu_clip_;
  Vec3 last_good_kinematic_accel_;  // stands in for a clipped accelerometer's (eq. 8.7)
  bool gyro_clipped_since_status_ = false;   // SYS_STATUS health: cleared bits for the whole period
  bool accel_clipped_since_status_ = false;
  uint8_t accel_count_ = 0;
  Vec3 star_ned_;
  est::MagCalibration mag_cal_;      // MAG_OFS_*, MAG_SI_*
  bool mag_cal_identity_ = true;     // MAG_OFS zero, MAG_SI the identity: eq. 7.5 is the field itself
  Vec3 mag_ref_magnetic_;            // Earth field learned at boot, magnetic north along x
  bool mag_ref_learned_ = false;

  ModeMachine modes_;
  ctrl::Cascade cascade_;
  ctrl::ManualControl manual_;
  ctrl::SetpointShaper shaper_;
  ctrl::PositionSetpoint setpoint_;
  uint8_t fixes_rejected_in_a_row_ = 0;  // vision fixes the filter refused since it last took one
  est::HoverAccelBias accel_bias_;  // the accelerometer's in-flight x/y bias drift
  PositionTrim trim_;
  ctrl::RcSticks sticks_;
  bool rc_switches_enabled_ = false;
  bool switches_known_ = false;  // the first frame only records the switch positions
  RcSwitches switches_;
  float land_thrust_max_ = 0.0f;  // N
  float landed_for_s_ = 0.0f;
  bool landed_ = true;
  float motors_[hal::kMotorCount] = {0.0f, 0.0f, 0.0f, 0.0f};
  float last_thrust_ = 0.0f;

  uint32_t now_us_ = 0;        // vehicle time: the last step, or (on a board) the last receive()
  uint32_t last_step_us_ = 0;  // time of the last control iteration, for its period
  uint64_t hil_time_usec_ = 0;
  bool clock_started_ = false;
  bool sensors_ok_ = false;
  bool rc_seen_ = false;
  uint32_t rc_time_us_ = 0;
  bool vision_seen_ = false;
  uint32_t vision_time_us_ = 0;

  int16_t param_stream_next_ = -1;  // next index of a PARAM_REQUEST_LIST being answered, -1 when idle
  uint8_t param_stream_port_ = 0;
  AppCounters counters_;
};

}  // namespace fw
}  // namespace quad
