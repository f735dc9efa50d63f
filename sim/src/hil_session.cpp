#include "quad/sim/hil_session.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "quad/link/dialect.h"
#include "quad/link/mavlink.h"
#include "quad/link/tlog.h"
#include "quad/sim/faults.h"
#include "quad/sim/firmware_process.h"
#include "quad/sim/hil_messages.h"
#include "quad/sim/log_download.h"
#include "quad/sim/frames.h"
#include "quad/sim/imu.h"
#include "quad/sim/magnetometer.h"
#include "quad/sim/metrics.h"
#include "quad/sim/progress_pace.h"
#include "quad/sim/pty.h"
#include "quad/sim/run_output.h"
#include "quad/sim/serial_line.h"
#include "quad/sim/ground_camera_loop.h"
#include "quad/sim/station_loop.h"
#include "quad/sim/udp_link.h"
#include "quad/sim/vehicle.h"
#include "quad/sim/external_pose_feed.h"
#include "quad/sim/vision_fix.h"

namespace quad::sim {
namespace mav = quad::mavlink;

namespace {

using Clock = std::chrono::steady_clock;

// The firmware's view, from its telemetry.
struct Telemetry {
  Eigen::Vector3d position_ned = Eigen::Vector3d::Constant(NAN);
  Eigen::Vector3d velocity_ned = Eigen::Vector3d::Constant(NAN);
  Eigen::Quaterniond q_ib{NAN, NAN, NAN, NAN};
  HeartbeatState heartbeat;
  uint64_t frames = 0;
};

class Session {
 public:
  Session(const Scenario& s, const SessionOptions& o);
  ~Session() {
    if (events_) std::fclose(events_);
    if (ground_) unlink(o_.ground_port_link.c_str());
  }
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
  SessionResult run();

 private:
  std::string firmware_params_text() const;
  void start_processes();
  void wait_for_firmware_hello();
  std::string control_period(double t, double period, double uart0_byte_s);
  std::string exchange_in_real_time(double t, double period, double uart0_byte_s);
  std::string exchange_in_lockstep(double t, double period, double uart0_byte_s);
  // Sending.
  template <class Msg>
  void send_uart0(const Msg& msg, mav::Sender& sender, double t);
  template <class Msg>
  void send_radio(const Msg& msg, mav::Sender& sender, double t);
  template <class Msg>
  void send_gcs(const Msg& msg, double t);
  void send_sensors(double t);
  void send_due_commands(double t);
  void send_rc(double t);

  // Receiving.
  void handle_frame(const mav::Frame& f, double t, const char* port);
  bool wait_for_answer(double t);
  double account_answer(double t, double period, double byte_s);
  void wait_radio_consumed();
  void deliver_radio(double until);
  void sample_sensors(double t);
  void poll_uart0(double t);
  void poll_uart2(double t);
  void poll_ground_port(double t);
  void poll_gcs_udp(double t);
  void poll_log_download(double t);
  void save_log_download();
  // The ground side of the radio: every frame into it passes here (recorded, then on the radio), and
  // every chunk out of it (recorded, to the ground port and the UDP ground station).
  void radio_uplink(const uint8_t* data, size_t size, double t);
  void radio_downlink(const uint8_t* data, size_t size, double t);
  uint64_t record_time_us(double t) const { return record_epoch_us_ + to_usec(t); }

  // The world.
  void apply_faults(double t);
  void physics_period(double t_end);
  void log_row(double t);
  void score_estimate(uint32_t time_boot_ms, const Eigen::Vector3d& estimate);
  void event(double t, const std::string& text);
  void write_summary(bool complete, const std::string& reason);
  void progress(double t, bool final_line);
  uint64_t vision_sent() const {
    return station_ ? station_->figures().fixes : ground_cams_ ? ground_cams_->figures().fixes : vision_.released();
  }
  std::vector<MarkedVehicle> marked_vehicles() const;

  const Scenario& s_;
  const SessionOptions& o_;
  Vehicle vehicle_;
  Mpu6000 imu_;
  Hmc5883l mag_;
  SimulatedVisionFix vision_;
  SimulatedExternalPose external_pose_;  // the motion-capture feed, when the scenario has one
  ImuReading imu_reading_{};
  bool mag_fresh_ = false;
  Eigen::Vector3d field_ned_;

  Pty uart0_, uart2_;
  SerialLine uart0_out_;   // simulator -> firmware on UART0 (pacing and statistics; lockstep flushes it)
  SerialLine radio_up_;    // ground and vision station -> firmware on UART2
  SerialLine radio_down_;  // firmware -> ground on UART2
  mav::Sender sensor_sender_{kVehicleSys, kSimComp};
  mav::Sender gcs_sender_{kGcsSys, mav::kCompIdMissionPlanner};
  // The scenario's log_download commands: a ground station's log download over the radio.
  LogDownload log_download_{LogDownload::Link{
      [this](const mav::LogRequestList& m, double t) { send_radio(m, gcs_sender_, t); },
      [this](const mav::LogRequestData& m, double t) { send_radio(m, gcs_sender_, t); },
      [this](const mav::LogRequestEnd& m, double t) { send_radio(m, gcs_sender_, t); }}};
  bool log_download_reported_ = false;
  mav::Parser uart0_parser_, uart2_splitter_, ground_splitter_;
  mav::Parser ground_parser_{mav::dialect_message_info};  // the downlink at the ground side
  std::unique_ptr<Pty> ground_;  // the base-station side of the radio, for outside programs (optional)
  uint64_t ground_dropped_ = 0;  // downlink bytes nobody read from the ground port
  std::unique_ptr<UdpLink> udp_;  // a ground station over UDP (optional)
  bool udp_heard_ = false;        // a datagram has arrived (events.log says when, once)
  uint64_t udp_peer_changes_ = 0; // as last reported in events.log
  // The link record (RUN/link.tlog): sim time t is stamped record_epoch_us_ + t, the wall clock at the
  // start of the run plus the simulated time, so the record reads as the flight's own timeline.
  std::unique_ptr<tlog::TlogWriter> record_;
  std::unique_ptr<tlog::TlogStream> record_up_, record_down_;
  uint64_t record_epoch_us_ = 0;
  std::unique_ptr<FirmwareProcess> firmware_;
  std::unique_ptr<StationLoop> station_;  // rendered cameras and the vision station (camera.enabled)
  std::unique_ptr<GroundCameraLoop> ground_cams_;  // room cameras and the ground-camera station (ground_cameras.enabled)

  // Schedules.
  size_t next_command_ = 0;
  double next_rc_t_ = 0.0;
  double next_frame_t_ = 0.0;
  std::optional<Eigen::Vector3d> setpoint_;
  double setpoint_yaw_ = 0.0, setpoint_time_ = -1.0;
  std::vector<bool> fault_active_;
  FaultEffects faults_now_;

  // The exchange. Answers take effect in order, each when its last byte has crossed UART0.
  std::deque<std::pair<double, std::array<double, 4>>> pending_commands_;  // (apply time, commands)
  std::optional<mav::HilActuatorControls> answer_;
  bool lockstep_mismatch_reported_ = false;  // an answer flagged for the other mode, said once
  uint64_t awaited_usec_ = 0;  // lockstep: the time stamp of the answer being waited for
  bool radio_written_ = false;
  bool firmware_spoke_first_ = false;
  uint64_t radio_sync_timeouts_ = 0;  // see wait_radio_consumed()
  int radio_sync_misses_in_row_ = 0;
  bool radio_ignored_ = false;
  std::vector<uint8_t> last_sensor_frame_;  // resent while the firmware is still starting
  uint64_t exchanges_ = 0, uart0_overruns_ = 0;
  // UART0 from the firmware, paced at uart0_baud in simulated time: the frames it sent since its last
  // answer, up to and including this one, belong to this exchange (acks, telemetry and status text all
  // precede the answer of the step they come with, so the count is the same in every run of a seed).
  uint64_t uart0_in_bytes_ = 0;           // every frame from the firmware on UART0
  uint64_t uart0_in_since_answer_ = 0;    // of those, since the last answer
  uint64_t uart0_in_exchange_bytes_ = 0;  // the exchange just closed by an answer
  uint64_t uart0_in_exchange_max_ = 0, uart0_in_exchange_sum_ = 0;
  uint64_t uart0_in_overruns_ = 0;        // answers that arrived after the end of their period
  double uart0_in_busy_until_ = 0.0;      // when the last byte counted so far has arrived
  double answer_delay_sum_s_ = 0.0, answer_delay_max_s_ = 0.0;  // HIL_SENSOR time stamp to commands applied
  Telemetry tele_;

  // Outputs.
  std::unique_ptr<CsvLog> log_;
  std::FILE* events_ = nullptr;
  FlightMetrics metrics_;
  ErrorStats est_horizontal_, est_vertical_;
  GroundMoves ground_moves_;  // the estimate after each touchdown (summary.json "landings")
  ErrorStats est_hold_horizontal_, est_hold_tilt_;  // the same within the hold; the attitude's tilt error
  std::deque<std::pair<long long, Eigen::Vector3d>> truth_history_;  // (ms, position) of the last rows
  std::optional<double> altitude_reached_s_;
  Clock::time_point wall_start_;
  Clock::time_point last_summary_;
  ProgressPace progress_pace_;
};

VehicleParams vehicle_params(const Scenario& s) {
  VehicleParams p;
  p.model_path = s.model_path;
  p.motor = s.motor;
  p.drag_linear_n_per_m_s = s.drag_linear;
  p.drag_quadratic_n_per_m2_s2 = s.drag_quadratic;
  return p;
}

FlightMetricsConfig metrics_config(const Scenario& s, double ground_down) {
  FlightMetricsConfig c;
  c.hold_start_s = s.hold_start_s;
  c.hold_end_s = s.hold_end_s;
  c.extra_holds = s.extra_holds;
  c.settle_band_m = s.settle_band_m;
  c.ground_down_m = ground_down;
  return c;
}

// The log holds only what is deterministic for a seed. The firmware's own traffic (what it sends after
// its answer) reaches us when the OS schedules it, so its counts are in summary.json, not per row.
const std::vector<std::string>& log_columns() {
  static const std::vector<std::string> c = {
      "t", "true_n", "true_e", "true_d", "true_vn", "true_ve", "true_vd", "true_roll", "true_pitch", "true_yaw",
      "true_p", "true_q", "true_r", "est_n", "est_e", "est_d", "est_vn", "est_ve", "est_vd", "est_roll",
      "est_pitch", "est_yaw", "sp_n", "sp_e", "sp_d", "sp_yaw", "cmd0", "cmd1", "cmd2", "cmd3", "thrust0",
      "thrust1", "thrust2", "thrust3", "mode", "armed", "imu_ax", "imu_ay", "imu_az", "imu_gx", "imu_gy",
      "imu_gz", "mag_x", "mag_y", "mag_z", "wind_n", "wind_e", "wind_d", "vision_sent", "uart0_tx_frames",
      "radio_up_sent", "radio_up_lost", "radio_up_corrupted", "radio_up_bytes", "radio_up_bits_flipped"};
  return c;
}

Session::Session(const Scenario& s, const SessionOptions& o)
    : s_(s),
      o_(o),
      vehicle_(vehicle_params(s)),
      imu_(s.imu, Rng(s.seed, "imu")),
      mag_(s.mag, Rng(s.seed, "magnetometer")),
      vision_(s.vision, Rng(s.seed, "vision")),
      external_pose_(s.external_pose, Rng(s.seed, "external_pose")),
      field_ned_(s.field_ned_gauss),
      uart0_(s.uart0_baud),
      uart2_(s.radio_baud),
      uart0_out_(s.uart0_baud, Rng(s.seed, "uart0")),
      radio_up_(s.radio_baud, Rng(s.seed, "radio_up")),
      radio_down_(s.radio_baud, Rng(s.seed, "radio_down")),
      fault_active_(s.faults.size(), false),
      metrics_(metrics_config(s, vehicle_.rest_down_m())),
      ground_moves_(vehicle_.rest_down_m()) {
  vehicle_.reset(s.initial_north_east_m, s.initial_height_m, s.initial_yaw_rad);
  if (s.initial_height_m == 0.0) vehicle_.settle_on_ground(0.5);
  radio_up_.set_radio(s.radio);
  radio_down_.set_radio(s.radio);
  make_directories(o.out_dir);
  if (!o.ground_port_link.empty()) {
    ground_ = std::make_unique<Pty>(s.radio_baud);
    unlink(o.ground_port_link.c_str());  // a stale link from an earlier run
    if (symlink(ground_->slave_path().c_str(), o.ground_port_link.c_str()) != 0)
      throw std::runtime_error(o.ground_port_link + ": cannot create the ground port link: " + std::strerror(errno));
  }
  if (o.gcs_udp) udp_ = std::make_unique<UdpLink>(*o.gcs_udp);
  if (o.link_record) {
    record_ = std::make_unique<tlog::TlogWriter>(o.out_dir + "/link.tlog");
    record_up_ = std::make_unique<tlog::TlogStream>(*record_);
    record_down_ = std::make_unique<tlog::TlogStream>(*record_);
  }
  log_ = std::make_unique<CsvLog>(o.out_dir + "/log.csv", log_columns());
  events_ = std::fopen((o.out_dir + "/events.log").c_str(), "w");
  if (!events_) throw std::runtime_error(o.out_dir + "/events.log: cannot create");
}

template <class Msg>
void Session::send_uart0(const Msg& msg, mav::Sender& sender, double t) {
  uint8_t buf[mav::max_frame_length<Msg>()];
  const size_t n = sender.encode(msg, buf, sizeof buf);
  uart0_out_.send(buf, n, t);
}

template <class Msg>
void Session::send_radio(const Msg& msg, mav::Sender& sender, double t) {
  uint8_t buf[mav::max_frame_length<Msg>()];
  const size_t n = sender.encode(msg, buf, sizeof buf);
  radio_uplink(buf, n, t);
}

template <class Msg>
void Session::send_gcs(const Msg& msg, double t) {
  if (s_.gcs_over_radio) send_radio(msg, gcs_sender_, t);
  else send_uart0(msg, gcs_sender_, t);
}

void Session::event(double t, const std::string& text) {
  std::fprintf(events_, "%9.3f %s\n", t, text.c_str());
  std::fflush(events_);
}

void Session::send_due_commands(double t) {
  while (next_command_ < s_.commands.size() && s_.commands[next_command_].at_s <= t + 1e-9) {
    const GcsCommand& c = s_.commands[next_command_++];
    if (c.setpoint_ned_m) {
      const mav::SetPositionTargetLocalNed sp = setpoint_message(c, t);
      send_gcs(sp, t);
      setpoint_ = c.setpoint_ned_m;
      setpoint_yaw_ = c.yaw_rad;
      setpoint_time_ = t;
      std::ostringstream e;
      e << "gcs: setpoint NED (" << sp.x << ", " << sp.y << ", " << sp.z << ") yaw " << sp.yaw;
      event(t, e.str());
      continue;
    }
    if (c.log_download) {
      log_download_.start(t, *c.log_download);
      log_download_reported_ = false;
      event(t, "gcs: log download over the radio");
      continue;
    }
    if (c.param_list) {
      mav::ParamRequestList list;
      list.target_system = kVehicleSys;
      list.target_component = mav::kCompIdAutopilot1;
      send_gcs(list, t);
      event(t, "gcs: parameter list");
      continue;
    }
    const CommandMessage cmd = command_long_message(c);
    send_gcs(cmd.message, t);
    event(t, "gcs: " + cmd.what);
  }
}

void Session::send_rc(double t) {
  if (t + 1e-9 < next_rc_t_) return;
  next_rc_t_ += 1.0 / s_.rc_rate_hz;
  if (fault_effects(s_.faults, s_.radio, t).rc_loss) return;
  RcSticks sticks;
  for (const RcSticks& r : s_.rc)
    if (r.at_s <= t) sticks = r;
  mav::ManualControl mc;
  mc.target = kVehicleSys;
  mc.x = static_cast<int16_t>(sticks.pitch);
  mc.y = static_cast<int16_t>(sticks.roll);
  mc.z = static_cast<int16_t>(sticks.throttle);
  mc.r = static_cast<int16_t>(sticks.yaw);
  send_uart0(mc, gcs_sender_, t);
}

void Session::send_sensors(double t) {
  const mav::HilSensor m = hil_sensor_message(t, imu_reading_, mag_.reading(), mag_fresh_);
  mag_fresh_ = false;
  uint8_t buf[mav::max_frame_length<mav::HilSensor>()];
  const size_t n = sensor_sender_.encode(m, buf, sizeof buf);
  last_sensor_frame_.assign(buf, buf + n);
  uart0_out_.send(buf, n, t);
}

void Session::apply_faults(double t) {
  for (size_t i = 0; i < s_.faults.size(); ++i) {
    const bool active = s_.faults[i].active(t);
    if (active == fault_active_[i]) continue;
    fault_active_[i] = active;
    event(t, std::string("fault: ") + fault_name(s_.faults[i].type) + (active ? " begins" : " ends"));
  }
  faults_now_ = fault_effects(s_.faults, s_.radio, t);
  radio_up_.set_radio(faults_now_.radio);
  radio_down_.set_radio(faults_now_.radio);
  field_ned_ = s_.field_ned_gauss + faults_now_.mag_offset_ned_gauss;
  imu_.set_gyro_bias_step(faults_now_.gyro_bias_step_rad_s);
  for (int i = 0; i < 4; ++i) vehicle_.set_motor_efficiency(i, faults_now_.motor_efficiency[static_cast<size_t>(i)]);
}

void Session::handle_frame(const mav::Frame& f, double t, const char* port) {
  if (f.system_id != kVehicleSys || f.component_id != mav::kCompIdAutopilot1) return;
  ++tele_.frames;
  // The logged estimate comes from UART0 only: it arrives in order with the lockstep answer, so the log
  // stays deterministic. What the ground station hears over the radio goes to the events log.
  const bool uart0 = port[0] == 'u';
  if (!uart0 && log_download_.active()) log_download_.on_frame(f, t);
  if (!uart0 && f.message_id != mav::Statustext::kId && f.message_id != mav::CommandAck::kId) return;
  switch (f.message_id) {
    case mav::HilActuatorControls::kId: {
      mav::HilActuatorControls m;
      if (!mav::decode(f, m)) break;
      answer_ = m;
      const bool lockstep_flag = (m.flags & mav::kHilActuatorControlsFlagLockstep) != 0;
      if (lockstep_flag == o_.realtime && !lockstep_mismatch_reported_) {
        // A firmware that did not get (or ignores) HIL_LOCKSTEP: the run goes on, the log says so.
        event(t, std::string("firmware answers flagged ") + (lockstep_flag ? "lockstep" : "real time") + " in a " +
                     (o_.realtime ? "real-time" : "lockstep") + " run");
        lockstep_mismatch_reported_ = true;
      }
      // The answer closes its exchange's byte count (a stale or repeated answer does not, in lockstep).
      if (o_.realtime || m.time_usec == awaited_usec_) {
        uart0_in_exchange_bytes_ += uart0_in_since_answer_;
        uart0_in_since_answer_ = 0;
      }
      break;
    }
    case mav::Heartbeat::kId: {
      mav::Heartbeat m;
      if (mav::decode(f, m) && tele_.heartbeat.update(m))
        event(t, std::string("firmware (") + port + "): " + tele_.heartbeat.text());
      break;
    }
    case mav::LocalPositionNed::kId: {
      mav::LocalPositionNed m;
      if (!mav::decode(f, m)) break;
      tele_.position_ned = {m.x, m.y, m.z};
      tele_.velocity_ned = {m.vx, m.vy, m.vz};
      score_estimate(m.time_boot_ms, tele_.position_ned);
      ground_moves_.add_estimate(1e-3 * static_cast<double>(m.time_boot_ms), tele_.position_ned);
      break;
    }
    case mav::AttitudeQuaternion::kId: {
      mav::AttitudeQuaternion m;
      if (mav::decode(f, m)) tele_.q_ib = Eigen::Quaterniond(m.q1, m.q2, m.q3, m.q4);
      break;
    }
    case mav::Statustext::kId: {
      mav::Statustext m;
      if (!mav::decode(f, m)) break;
      const std::string text(m.text, strnlen(m.text, sizeof m.text));
      event(t, std::string("firmware (") + port + "): " + text);
      break;
    }
    case mav::CommandAck::kId: {
      mav::CommandAck m;
      if (!mav::decode(f, m)) break;
      event(t, std::string("firmware (") + port + "): COMMAND_ACK " + std::to_string(m.command) + " result " +
                   std::to_string(m.result));
      break;
    }
    default: break;
  }
}

void Session::poll_uart0(double t) {
  uint8_t buf[4096];
  for (size_t n; (n = uart0_.read_some(buf, sizeof buf)) > 0;)
    uart0_parser_.feed(buf, n, [&](const mav::Frame& f) {
      uart0_in_bytes_ += f.size;  // every frame occupies the wire, whoever it is from
      uart0_in_since_answer_ += f.size;
      handle_frame(f, t, "uart0");
    });
}

void Session::poll_ground_port(double t) {
  // Frames from outside programs at the base station enter the radio at the current simulated time.
  if (!ground_) return;
  uint8_t buf[4096];
  for (size_t n; (n = ground_->read_some(buf, sizeof buf)) > 0;)
    ground_splitter_.feed(buf, n, [&](const mav::Frame& f) { radio_uplink(f.bytes, f.size, t); });
}

void Session::poll_gcs_udp(double t) {
  // A datagram crosses the radio as one packet at the current simulated time, whatever it holds:
  // frames the firmware does not know take their share of the radio too, and the firmware drops them.
  if (!udp_) return;
  uint8_t buf[2048];
  for (size_t n; (n = udp_->receive(buf, sizeof buf)) > 0;) radio_uplink(buf, n, t);
  if (udp_->stats().datagrams_received > 0 && !udp_heard_) {
    udp_heard_ = true;
    event(t, "gcs udp: first datagram from " + udp_->peer());
  }
  if (udp_->stats().peer_changes != udp_peer_changes_) {
    udp_peer_changes_ = udp_->stats().peer_changes;
    event(t, "gcs udp: sending to " + udp_->peer() + " (the latest sender)");
  }
}

void Session::poll_log_download(double t) {
  if (log_download_.active()) log_download_.poll(t);
  if (!log_download_.started() || log_download_.active() || log_download_reported_) return;
  log_download_reported_ = true;
  event(t, log_download_.describe());
  save_log_download();
}

// RUN/log_download.ulg: the downloaded bytes from the start of the log up to the first one missing.
void Session::save_log_download() {
  const std::vector<uint8_t> bytes = log_download_.contiguous();
  write_file_atomically(o_.out_dir + "/log_download.ulg", std::string(bytes.begin(), bytes.end()));
}

void Session::radio_uplink(const uint8_t* data, size_t size, double t) {
  if (record_up_) record_up_->feed(data, size, record_time_us(t));
  radio_up_.send(data, size, t);
}

void Session::radio_downlink(const uint8_t* data, size_t size, double t) {
  if (record_down_) record_down_->feed(data, size, record_time_us(t));
  if (ground_) ground_dropped_ += ground_->write_or_drop(data, size);
  ground_parser_.feed(data, size, [&](const mav::Frame& f) {
    if (udp_) udp_->send(f.bytes, f.size);  // whole frames, one per datagram, as a SITL sends them
    handle_frame(f, t, "radio");
  });
}

void Session::poll_uart2(double t) {
  // The firmware's radio output: split into frames, each crosses the radio to the ground station.
  uint8_t buf[4096];
  for (size_t n; (n = uart2_.read_some(buf, sizeof buf)) > 0;)
    uart2_splitter_.feed(buf, n, [&](const mav::Frame& f) { radio_down_.send(f.bytes, f.size, t); });
}

void Session::wait_radio_consumed() {
  // Radio bytes for this step were written right after the last answer (run()). The firmware must have
  // read them before this step's HIL_SENSOR, as on the vehicle; two ptys give no order between them, so
  // wait until UART2's input queue is empty (yielding at first, then sleeping, so a loaded machine still
  // schedules the firmware). A firmware that leaves them unread for 200 ms three times in a row is taken
  // to ignore UART2, and not waited for again.
  if (!radio_written_ || radio_ignored_) return;
  radio_written_ = false;
  const auto start = Clock::now();
  while (uart2_.unread_by_peer() > 0) {
    const auto waited = Clock::now() - start;
    if (waited > std::chrono::milliseconds(200)) {
      ++radio_sync_timeouts_;
      if (++radio_sync_misses_in_row_ == 3) {
        radio_ignored_ = true;
        event(vehicle_.time(), "the firmware does not read UART2: radio bytes are no longer ordered with HIL_SENSOR");
      }
      return;
    }
    if (waited < std::chrono::microseconds(100)) std::this_thread::yield();
    else std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  radio_sync_misses_in_row_ = 0;
}

bool Session::wait_for_answer(double t) {
  const uint64_t want = to_usec(t);
  awaited_usec_ = want;
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o_.answer_timeout_s));
  answer_.reset();
  // A silent firmware (one that did not speak before the first HIL_SENSOR, see run()) may open and
  // flush its port after that message was written: until its first answer the message is repeated every
  // 250 ms. A repeat the firmware does see costs it an extra iteration, so it is the fallback only.
  auto next_resend = Clock::now() + std::chrono::milliseconds(250);
  // handle_frame() keeps the latest HIL_ACTUATOR_CONTROLS; anything but this step's answer is stale.
  while (!(answer_ && answer_->time_usec == want)) {
    const auto now = Clock::now();
    if (now >= deadline || !firmware_->running()) return false;
    if (exchanges_ == 0 && !firmware_spoke_first_ && now >= next_resend) {
      uart0_.write_all(last_sensor_frame_.data(), last_sensor_frame_.size());
      next_resend = now + std::chrono::milliseconds(250);
    }
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - now).count();
    if (uart0_.wait_readable(static_cast<int>(std::min<long>(left, 100)) + 1)) poll_uart0(t);
  }
  return true;
}

// The firmware's bytes of the exchange at t on UART0, paced at the baud in simulated time: the firmware
// starts answering when the HIL_SENSOR has arrived (uart0_out_ holds it and the commands and RC sent
// ahead of it), its bytes follow anything still on the wire, and the answer is their last frame.
// Returns when the answer's last byte arrives; an answer arriving after the end of its period is an
// overrun (the firmware's output does not fit the baud at this rate).
double Session::account_answer(double t, double period, double byte_s) {
  const double start = std::max(uart0_out_.busy_until(), uart0_in_busy_until_);
  const double arrival = start + byte_s * static_cast<double>(uart0_in_exchange_bytes_);
  uart0_in_busy_until_ = arrival;
  uart0_in_exchange_max_ = std::max(uart0_in_exchange_max_, uart0_in_exchange_bytes_);
  uart0_in_exchange_sum_ += uart0_in_exchange_bytes_;
  answer_delay_sum_s_ += arrival - t;
  answer_delay_max_s_ = std::max(answer_delay_max_s_, arrival - t);
  if (arrival > t + period + 1e-12 && uart0_in_overruns_++ == 0) {
    char text[160];
    std::snprintf(text, sizeof text, "uart0: the firmware's %llu bytes for this step do not fit %d baud "
                  "(answer %.2f ms after HIL_SENSOR, period %.2f ms)", static_cast<unsigned long long>(uart0_in_exchange_bytes_),
                  s_.uart0_baud, 1e3 * (arrival - t), 1e3 * period);
    event(t, text);
  }
  uart0_in_exchange_bytes_ = 0;
  return arrival;
}

void Session::sample_sensors(double t) {
  const VehicleTruth truth = vehicle_.truth();
  imu_reading_ = apply_imu_fault(imu_.sample(truth.specific_force_frd, truth.rate_frd, vehicle_.mean_speed_fraction()),
                                 faults_now_.imu, imu_.params());
  if (s_.mag.present && mag_.update(t, truth.q_ib.conjugate() * field_ned_)) mag_fresh_ = true;
}

void Session::deliver_radio(double until) {
  radio_up_.deliver_until(until, [&](const uint8_t* d, size_t n) {
    uart2_.write_all(d, n);
    radio_written_ = true;
    if (ground_cams_) ground_cams_->delivered(kVehicleSys, until, d, n);
  });
}

// The vehicle as the room cameras see it: its pose and the scenario's marker layout.
std::vector<MarkedVehicle> Session::marked_vehicles() const {
  const VehicleTruth truth = vehicle_.truth();
  MarkedVehicle v;
  v.id = kVehicleSys;
  v.p_ned = truth.position_ned;
  v.q_ib = truth.q_ib;
  v.markers_frd = s_.ground_cameras.markers_frd;
  v.marker_radius_m = s_.ground_cameras.marker_radius_m;
  return {v};
}

void Session::physics_period(double t_end) {
  const double dt = vehicle_.timestep();
  while (vehicle_.time() < t_end - 0.5 * dt) {
    const double t = vehicle_.time();
    while (!pending_commands_.empty() && t + 1e-9 >= pending_commands_.front().first) {
      vehicle_.set_commands(pending_commands_.front().second);
      pending_commands_.pop_front();
    }
    apply_faults(t);
    vehicle_.set_wind_ned(s_.wind_at(t));
    vehicle_.step();
    sample_sensors(t);
    const double now = vehicle_.time();
    const VehicleTruth truth = vehicle_.truth();
    const FaultEffects faults = fault_effects(s_.faults, s_.radio, now);
    if (station_) {
      // Rendered cameras and the vision station; a vision dropout hides the star.
      const auto& decoy = faults.vision_errors.decoy_ned;
      station_->update(now, truth.position_ned, truth.q_ib, faults.vision_dropout,
                       [&](double when, const uint8_t* d, size_t n) { radio_uplink(d, n, when); },
                       decoy ? std::optional<Eigen::Vector2d>(decoy->head<2>()) : std::nullopt);
    } else if (ground_cams_) {
      ground_cams_->update(now, marked_vehicles(),
                           [&](int, double when, const uint8_t* d, size_t n) { radio_uplink(d, n, when); });
    } else {
      vision_.update(now, truth.position_ned, truth.q_ib, faults.vision_dropout, faults.vision_errors);
      vision_.release_until(now, [&](double when, const uint8_t* d, size_t n) { radio_uplink(d, n, when); });
    }
    external_pose_.update(now, truth.position_ned, truth.q_ib, faults.vision_dropout);
    external_pose_.release_until(now, [&](double when, const uint8_t* d, size_t n) { radio_uplink(d, n, when); });
    if (o_.realtime) deliver_radio(now);
    radio_down_.deliver_until(now, [&](const uint8_t* d, size_t n) { radio_downlink(d, n, now); });
    if (o_.on_frame && now + 1e-9 >= next_frame_t_) {
      next_frame_t_ += 1.0 / o_.frame_rate_hz;
      o_.on_frame(vehicle_);
    }
  }
}

void Session::log_row(double t) {
  const VehicleTruth tr = vehicle_.truth();
  const Eigen::Vector3d e = euler_from_q_ib(tr.q_ib);
  const Eigen::Vector3d ee = std::isnan(tele_.q_ib.w()) ? Eigen::Vector3d::Constant(NAN) : euler_from_q_ib(tele_.q_ib);
  const Eigen::Vector3d sp = setpoint_ ? *setpoint_ : Eigen::Vector3d::Constant(NAN);
  const Eigen::Vector3d w = s_.wind_at(t);
  const auto& c = vehicle_.commands();
  const auto& u0 = uart0_out_.stats();
  const auto& ru = radio_up_.stats();
  log_->row({t, tr.position_ned.x(), tr.position_ned.y(), tr.position_ned.z(), tr.velocity_ned.x(),
             tr.velocity_ned.y(), tr.velocity_ned.z(), e.x(), e.y(), e.z(), tr.rate_frd.x(), tr.rate_frd.y(),
             tr.rate_frd.z(), tele_.position_ned.x(), tele_.position_ned.y(), tele_.position_ned.z(),
             tele_.velocity_ned.x(), tele_.velocity_ned.y(), tele_.velocity_ned.z(), ee.x(), ee.y(), ee.z(), sp.x(),
             sp.y(), sp.z(), setpoint_ ? setpoint_yaw_ : NAN, c[0], c[1], c[2], c[3], vehicle_.motor(0).thrust_n(),
             vehicle_.motor(1).thrust_n(), vehicle_.motor(2).thrust_n(), vehicle_.motor(3).thrust_n(),
             static_cast<double>(tele_.heartbeat.mode), tele_.heartbeat.armed ? 1.0 : 0.0, imu_reading_.specific_force_frd.x(),
             imu_reading_.specific_force_frd.y(), imu_reading_.specific_force_frd.z(), imu_reading_.rate_frd.x(),
             imu_reading_.rate_frd.y(), imu_reading_.rate_frd.z(), mag_.reading().x(), mag_.reading().y(),
             mag_.reading().z(), w.x(), w.y(), w.z(), static_cast<double>(vision_sent()),
             static_cast<double>(u0.frames_sent), static_cast<double>(ru.frames_sent),
             static_cast<double>(ru.frames_lost), static_cast<double>(ru.frames_corrupted),
             static_cast<double>(ru.bytes_sent), static_cast<double>(ru.bits_flipped)});
  const double tilt = std::acos(std::clamp((tr.q_ib * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0));
  metrics_.add(t, tr.position_ned, tr.velocity_ned, tilt, setpoint_, setpoint_time_);
  ground_moves_.add_truth(t, tr.position_ned);
  if (t >= s_.hold_start_s && t <= s_.hold_end_s && !std::isnan(tele_.q_ib.w())) {
    // The angle between the true and the estimated body z (the latest attitude telemetry).
    const Eigen::Vector3d z_true = tr.q_ib * Eigen::Vector3d::UnitZ(), z_est = tele_.q_ib * Eigen::Vector3d::UnitZ();
    est_hold_tilt_.add(std::atan2(z_true.cross(z_est).norm(), z_true.dot(z_est)));
  }
  truth_history_.emplace_back(std::llround(t * 1000.0), tr.position_ned);
  if (truth_history_.size() > 200) truth_history_.pop_front();  // 2 s at 100 Hz
  if (setpoint_ && !altitude_reached_s_ && std::abs(tr.position_ned.z() - setpoint_->z()) < 0.05)
    altitude_reached_s_ = t - setpoint_time_;
}

void Session::score_estimate(uint32_t time_boot_ms, const Eigen::Vector3d& estimate) {
  // Against the truth at the estimate's own time (the firmware stamps it with the HIL clock), so the
  // telemetry's age does not count as estimation error. Only while armed: the flight, not the bench.
  if (!tele_.heartbeat.armed || !estimate.allFinite()) return;
  for (auto it = truth_history_.rbegin(); it != truth_history_.rend(); ++it) {
    if (it->first != static_cast<long long>(time_boot_ms)) continue;
    est_horizontal_.add((estimate - it->second).head<2>().norm());
    est_vertical_.add(estimate.z() - it->second.z());
    const double t = 1e-3 * static_cast<double>(time_boot_ms);
    if (t >= s_.hold_start_s && t <= s_.hold_end_s) est_hold_horizontal_.add((estimate - it->second).head<2>().norm());
    return;
  }
}

Json station_json(const StationFigures& f, const Scenario& s) {
  Json j;
  j.add("pairs_captured", static_cast<long>(f.pairs_captured)).add("pairs_lost", static_cast<long>(f.pairs_lost));
  j.add("pairs_answered", static_cast<long>(f.pairs_answered)).add("fixes", static_cast<long>(f.fixes));
  j.add("covariances", static_cast<long>(f.covariances));
  j.add("fix_rate", f.pairs_answered ? static_cast<double>(f.fixes) / static_cast<double>(f.pairs_answered) : 0.0);
  j.add("fix_error_m", percentiles_json(f.fix_error_m));
  j.add("processing_us", percentiles_json(f.processing_us));
  j.add("configured_latency_s", s.vision.latency_s).add("late_answers", static_cast<long>(f.late_answers));
  return j;
}

Json stats_json(const ErrorStats& e) {
  Json j;
  j.add("mean", e.mean()).add("std", e.stddev()).add("rms", e.rms()).add("max_abs", e.max_abs());
  return j;
}

Json udp_json(const UdpLink& udp) {
  const UdpLinkStats& st = udp.stats();
  Json j;
  j.add("configured", udp.configured()).add("peer", udp.peer()).add("local_port", static_cast<long>(udp.local_port()));
  j.add("datagrams_sent", static_cast<long>(st.datagrams_sent)).add("datagrams_dropped", static_cast<long>(st.datagrams_dropped))
      .add("datagrams_received", static_cast<long>(st.datagrams_received))
      .add("bytes_received", static_cast<long>(st.bytes_received)).add("peer_changes", static_cast<long>(st.peer_changes));
  return j;
}

// What the link record holds, and what it could not (unknown message ids, damaged frames).
Json record_json(const tlog::TlogWriter& w, const tlog::TlogStream& up, const tlog::TlogStream& down) {
  auto direction = [](const tlog::TlogStream& s) {
    Json j;
    j.add("frames", static_cast<long>(s.stats().frames_accepted)).add("bad_checksum", static_cast<long>(s.stats().bad_checksum))
        .add("unknown_message", static_cast<long>(s.stats().unknown_message));
    return j;
  };
  Json j;
  j.add("file", "link.tlog").add("records", static_cast<long>(w.records()));
  j.add("to_vehicle", direction(up)).add("from_vehicle", direction(down));
  return j;
}

void Session::write_summary(bool complete, const std::string& reason) {
  const double wall = std::chrono::duration<double>(Clock::now() - wall_start_).count();
  const double sim = vehicle_.time();
  Json hold;
  hold.add("start_s", s_.hold_start_s).add("end_s", s_.hold_end_s).add("samples", metrics_.hold(0).count());
  hold.add("north", stats_json(metrics_.hold(0))).add("east", stats_json(metrics_.hold(1)));
  hold.add("vertical", stats_json(metrics_.hold(2)));
  Json horizontal;
  horizontal.add("std_2d", metrics_.horizontal_stddev())
      .add("rms", metrics_.hold_horizontal().rms())
      .add("mean", metrics_.hold_horizontal().mean())
      .add("max", metrics_.hold_horizontal().max_abs());
  hold.add("horizontal", horizontal);
  // The further windows as "holds": {"1": ..., "2": ...}, each laid out as "hold".
  Json holds;
  for (size_t i = 0; i < metrics_.extra_holds().size(); ++i) {
    const HoldStats& h = metrics_.extra_holds()[i];
    Json w, wh;
    w.add("start_s", h.start_s).add("end_s", h.end_s).add("samples", h.axis[0].count());
    w.add("north", stats_json(h.axis[0])).add("east", stats_json(h.axis[1])).add("vertical", stats_json(h.axis[2]));
    wh.add("std_2d", h.horizontal_stddev()).add("rms", h.horizontal.rms()).add("mean", h.horizontal.mean())
        .add("max", h.horizontal.max_abs());
    w.add("horizontal", wh);
    holds.add(std::to_string(i + 1), w);
  }
  // After each touchdown: {"1": ..., "2": ...} in the order of the landings.
  Json landings;
  for (size_t i = 0; i < ground_moves_.landings().size(); ++i) {
    const LandingMove& m = ground_moves_.landings()[i];
    Json l;
    l.add("touchdown_s", m.touchdown_s).add("window_s", m.window_s).add("move_m", m.move_m)
        .add("horizontal_m", m.horizontal_m).add("vertical_m", m.vertical_m);
    landings.add(std::to_string(i + 1), l);
  }
  Json est;
  est.add("horizontal_rms_m", est_horizontal_.rms()).add("vertical_rms_m", est_vertical_.rms())
      .add("samples", est_horizontal_.count());
  Json est_hold;
  est_hold.add("horizontal_rms_m", est_hold_horizontal_.rms()).add("samples", est_hold_horizontal_.count())
      .add("tilt_rms_deg", est_hold_tilt_.rms() * 180.0 / M_PI).add("tilt_samples", est_hold_tilt_.count());
  est.add("hold", est_hold);
  auto line_json = [](const LineStats& l) {
    Json j;
    j.add("frames_sent", static_cast<long>(l.frames_sent)).add("frames_lost", static_cast<long>(l.frames_lost))
        .add("frames_corrupted", static_cast<long>(l.frames_corrupted)).add("bytes_sent", static_cast<long>(l.bytes_sent));
    return j;
  };
  Json links;
  Json uart0_in;
  const double per_exchange = exchanges_ ? 1.0 / static_cast<double>(exchanges_) : 0.0;
  uart0_in.add("frames_received", static_cast<long>(uart0_parser_.stats().frames_accepted))
      .add("bad_checksum", static_cast<long>(uart0_parser_.stats().bad_checksum))
      .add("sequence_lost", static_cast<long>(uart0_parser_.stats().sequence_lost))
      .add("bytes_received", static_cast<long>(uart0_in_bytes_))
      .add("bytes_per_exchange_mean", static_cast<double>(uart0_in_exchange_sum_) * per_exchange)
      .add("bytes_per_exchange_max", static_cast<long>(uart0_in_exchange_max_))
      .add("budget_bytes_per_period", s_.uart0_baud / 10.0 / s_.control_rate_hz)
      .add("answer_delay_s_mean", answer_delay_sum_s_ * per_exchange)
      .add("answer_delay_s_max", answer_delay_max_s_)
      .add("overruns", static_cast<long>(uart0_in_overruns_));
  Json ground_in;
  ground_in.add("frames_received", static_cast<long>(ground_parser_.stats().frames_accepted))
      .add("bad_checksum", static_cast<long>(ground_parser_.stats().bad_checksum))
      .add("sequence_lost", static_cast<long>(ground_parser_.stats().sequence_lost));
  links.add("uart0_to_firmware", line_json(uart0_out_.stats())).add("uart0_from_firmware", uart0_in);
  links.add("radio_uplink", line_json(radio_up_.stats())).add("radio_downlink", line_json(radio_down_.stats()));
  links.add("ground_station_received", ground_in).add("uart0_overruns", static_cast<long>(uart0_overruns_));
  links.add("radio_sync_timeouts", static_cast<long>(radio_sync_timeouts_));
  if (ground_) links.add("ground_port_bytes_dropped", static_cast<long>(ground_dropped_));
  if (udp_) links.add("gcs_udp", udp_json(*udp_));
  if (record_) links.add("link_record", record_json(*record_, *record_up_, *record_down_));
  Json j;
  j.add("scenario", s_.name).add("scenario_file", s_.path).add("seed", static_cast<long>(s_.seed));
  j.add("complete", complete);
  if (!complete) j.add("cut_short", reason);
  j.add("mode", o_.realtime ? "realtime" : "lockstep").add("sim_time_s", sim).add("wall_time_s", wall);
  j.add("real_time_factor", wall > 0 ? sim / wall : 0.0).add("lockstep_exchanges", static_cast<long>(exchanges_));
  j.add("hold", hold);
  if (!metrics_.extra_holds().empty()) j.add("holds", holds);
  if (!ground_moves_.landings().empty()) j.add("landings", landings);
  if (auto st = metrics_.settling_time_s()) j.add("settling_time_s", *st);
  else j.add_null("settling_time_s");
  if (altitude_reached_s_) j.add("altitude_reached_s", *altitude_reached_s_);
  else j.add_null("altitude_reached_s");
  j.add("crashed", metrics_.crashed());
  if (metrics_.crashed()) j.add("crash_time_s", metrics_.crash_time_s());
  j.add("estimate_vs_truth", est).add("vision_fixes_sent", static_cast<long>(vision_.released()))
      .add("external_poses_sent", static_cast<long>(external_pose_.released())).add("links", links);
  if (log_download_.started()) {
    const LogDownload& d = log_download_;
    Json ld;
    ld.add("file", "log_download.ulg").add("id", static_cast<long>(d.id())).add("listed_size", static_cast<long>(d.listed_size()))
        .add("wanted", static_cast<long>(d.wanted())).add("bytes_received", static_cast<long>(d.bytes_received()))
        .add("frames", static_cast<long>(d.frames_received())).add("data_requests", d.data_requests())
        .add("complete", d.complete()).add("started_s", d.started_s()).add("data_started_s", d.data_started_s())
        .add("finished_s", d.finished_s()).add("rate_bytes_s", d.rate_bytes_s());
    if (!d.failure().empty()) ld.add("failure", d.failure());
    j.add("log_download", ld);
  }
  if (station_) j.add("vision_station", station_json(station_->figures(), s_));
  if (ground_cams_) j.add("ground_station", ground_station_json(ground_cams_->figures(), s_.ground_cameras));
  write_file_atomically(o_.out_dir + "/summary.json", j.str() + "\n");
}

void Session::progress(double t, bool final_line) {
  const auto now = Clock::now();
  if (!o_.progress || !progress_pace_.due(now, final_line)) return;
  const double wall = std::chrono::duration<double>(now - wall_start_).count();
  const VehicleTruth tr = vehicle_.truth();
  char err[32] = "     -";
  if (setpoint_) std::snprintf(err, sizeof err, "%6.3f", (tr.position_ned - *setpoint_).norm());
  const std::string mode = tele_.heartbeat.mode_name();
  std::fprintf(stderr, "\r  t %6.1f / %.0f s | %6.1fx real time | error %s m | height %5.2f m | %-8s%s", t,
               s_.duration_s, wall > 0 ? t / wall : 0.0, err, -(tr.position_ned.z() - vehicle_.rest_down_m()), mode.c_str(),
               final_line ? "\n" : "");
  std::fflush(stderr);
}

// The firmware's parameter file of this run: the scenario's parameters and the mode it steps in (the
// firmware flags its answers with it, docs/hil-protocol.md).
std::string Session::firmware_params_text() const {
  std::string params = "# firmware parameters of this run (quad_sim, scenario " + s_.name + ")\n";
  for (const auto& [name, value] : s_.firmware_params) {
    char line[96];
    std::snprintf(line, sizeof line, "%s %.9g\n", name.c_str(), value);
    params += line;
  }
  const bool scenario_sets_it = std::any_of(s_.firmware_params.begin(), s_.firmware_params.end(),
                                            [](const auto& p) { return p.first == "HIL_LOCKSTEP"; });
  if (!scenario_sets_it) params += o_.realtime ? "HIL_LOCKSTEP 0\n" : "HIL_LOCKSTEP 1\n";
  return params;
}

// Writes the parameter file, starts the vision station (rendered cameras) and the firmware process.
void Session::start_processes() {
  write_file_atomically(o_.out_dir + "/firmware_params.txt", firmware_params_text());
  std::vector<std::string> argv = o_.firmware_argv;
  for (const std::string& a : {std::string("--uart0"), uart0_.slave_path(), std::string("--uart0-baud"),
                               std::to_string(s_.uart0_baud), std::string("--uart2"), uart2_.slave_path(),
                               std::string("--uart2-baud"), std::to_string(s_.radio_baud), std::string("--params"),
                               o_.out_dir + "/firmware_params.txt"})
    argv.push_back(a);
  {
    std::string cmd;
    for (const auto& a : argv) cmd += (cmd.empty() ? "" : " ") + a;
    event(0.0, "start: " + cmd);
    if (ground_) event(0.0, "ground port: " + o_.ground_port_link + " -> " + ground_->slave_path());
    if (udp_) event(0.0, "gcs udp: local port " + std::to_string(udp_->local_port()) + ", sending to " + udp_->peer());
  }
  if (s_.camera.enabled) {
    if (o_.station_argv.empty()) throw std::runtime_error(s_.path + ": camera.enabled needs the vision station command");
    StationLoopOptions station;
    station.calibration_file = o_.station_calibration;
    station.calibration_cache = o_.station_calibration_cache;
    station.progress = [this](const std::string& line) {
      event(0.0, line);
      if (o_.progress) std::fprintf(stderr, "%s\n", line.c_str());
    };
    station_ = std::make_unique<StationLoop>(s_, stereo_rig_from_model(vehicle_.model(), s_.camera, s_.model_path), o_.out_dir,
                                             o_.station_argv, station);
    event(0.0, "vision station: rendered cameras in the loop (station.log)");
  }
  if (s_.ground_cameras.enabled) {
    if (o_.station_argv.empty()) throw std::runtime_error(s_.path + ": ground_cameras.enabled needs the vision station command");
    GroundCameraLoopOptions ground;
    ground.room_file = o_.room_calibration;
    ground.room_cache = o_.station_calibration_cache;
    ground.progress = [this](const std::string& line) {
      event(0.0, line);
      if (o_.progress) std::fprintf(stderr, "%s\n", line.c_str());
    };
    ground_cams_ = std::make_unique<GroundCameraLoop>(s_.ground_cameras, s_.seed, s_.radio_baud, marked_vehicles(), o_.out_dir,
                                                      o_.station_argv, ground);
    event(0.0, "ground station: room cameras in the loop (ground_station.log)");
  }
  firmware_ = std::make_unique<FirmwareProcess>(argv, o_.out_dir + "/firmware.log");
}

// The firmware opens its ports, flushes them and announces itself (STATUSTEXT): wait for that, and for
// 100 ms of quiet after it (the end of its start-up), before the first HIL_SENSOR, so that no sensor
// message is lost to the flush or seen twice.
void Session::wait_for_firmware_hello() {
  const auto hello_deadline = Clock::now() + std::chrono::milliseconds(1500);
  while (Clock::now() < hello_deadline && firmware_->running()) {
    if (uart0_.wait_readable(100)) poll_uart0(0.0);
    else if (tele_.frames > 0) break;
  }
  firmware_spoke_first_ = tele_.frames > 0;
}

// Real time: bytes leave at their serial times and the latest answer is used. Empty, or why the run ends.
std::string Session::exchange_in_real_time(double t, double period, double uart0_byte_s) {
  const double wall_t = std::chrono::duration<double>(Clock::now() - wall_start_).count();
  if (wall_t < t) std::this_thread::sleep_for(std::chrono::duration<double>(t - wall_t));
  uart0_out_.deliver_until(t + period, [&](const uint8_t* d, size_t n) { uart0_.write_all(d, n); });
  answer_.reset();
  poll_uart0(t);
  if (answer_) {
    account_answer(t, period, uart0_byte_s);  // counted; the answer itself applies now (wall clock)
    std::array<double, 4> c;
    for (size_t i = 0; i < 4; ++i) c[i] = answer_->controls[i];
    pending_commands_.emplace_back(t, c);
    ++exchanges_;
  }
  if (!firmware_->running()) return "the firmware " + firmware_->status();
  return "";
}

// Lockstep: everything queued for UART0 goes now, and the firmware answers this step before the
// simulation moves. Empty, or why the run ends.
std::string Session::exchange_in_lockstep(double t, double period, double uart0_byte_s) {
  uart0_out_.deliver_until(1e18, [&](const uint8_t* d, size_t n) { uart0_.write_all(d, n); });
  if (!wait_for_answer(t)) {
    return firmware_->running() ? "the firmware did not answer HIL_SENSOR at t = " + std::to_string(t) +
                                      " s within " + std::to_string(o_.answer_timeout_s) + " s"
                                : "the firmware " + firmware_->status() + " (see firmware.log)";
  }
  ++exchanges_;
  // The commands take effect when the answer's last byte has arrived: after the HIL_SENSOR (and whatever
  // went out ahead of it) on the way there, and after the firmware's bytes of this exchange, behind
  // anything still on the wire from earlier ones.
  std::array<double, 4> c;
  for (size_t i = 0; i < 4; ++i) c[i] = answer_->controls[i];
  pending_commands_.emplace_back(account_answer(t, period, uart0_byte_s), c);
  // Radio bytes arriving during this period can only be acted on at the next step: hand them over now,
  // while the firmware waits, so they are read before the next HIL_SENSOR (deterministic order). Vision
  // and radio latencies exceed the period, so everything arriving by t + T is queued by now.
  deliver_radio(t + period);
  return "";
}

// One control period from t: the ground's inputs, the sensors, the firmware's answer, the radio, the
// physics and the records. Empty, or why the run ends.
std::string Session::control_period(double t, double period, double uart0_byte_s) {
  if (o_.stop && o_.stop->load()) return "interrupted";
  if (!o_.realtime) wait_radio_consumed();
  send_due_commands(t);
  send_rc(t);
  send_sensors(t);
  if (uart0_out_.busy_until() > t + period) ++uart0_overruns_;
  const std::string stopped =
      o_.realtime ? exchange_in_real_time(t, period, uart0_byte_s) : exchange_in_lockstep(t, period, uart0_byte_s);
  if (!stopped.empty()) return stopped;
  poll_uart2(t);
  poll_ground_port(t);
  poll_gcs_udp(t);
  poll_log_download(t);
  try {
    physics_period(t + period);
  } catch (const StationError& e) {
    // Ctrl-C reaches the station too (same process group): then the run was interrupted, not failed.
    return o_.stop && o_.stop->load() ? "interrupted" : e.what();
  }
  log_row(vehicle_.time());
  progress(vehicle_.time(), false);
  if (Clock::now() - last_summary_ > std::chrono::seconds(2)) {
    last_summary_ = Clock::now();
    write_summary(false, "running");
  }
  return "";
}

SessionResult Session::run() {
  start_processes();
  wall_start_ = last_summary_ = Clock::now();
  record_epoch_us_ = tlog::unix_micros_now();
  write_summary(false, "running");
  wait_for_firmware_hello();
  // The first HIL_SENSOR carries a real sample of the vehicle at rest (the IMU and magnetometer then
  // sample once per physics step).
  sample_sensors(0.0);

  wall_start_ = Clock::now();  // real time runs from the first exchange
  const double period = 1.0 / s_.control_rate_hz;
  const long periods = std::lround(s_.duration_s * s_.control_rate_hz);
  const double uart0_byte_s = 10.0 / s_.uart0_baud;  // 8N1
  std::string reason;
  for (long k = 0; k < periods && reason.empty(); ++k) reason = control_period(k * period, period, uart0_byte_s);

  SessionResult result;
  result.complete = reason.empty();
  result.reason = reason;
  result.sim_time_s = vehicle_.time();
  result.wall_time_s = std::chrono::duration<double>(Clock::now() - wall_start_).count();
  result.crashed = metrics_.crashed();
  progress(vehicle_.time(), true);
  if (record_) record_->flush();
  if (log_download_.active()) {
    event(vehicle_.time(), log_download_.describe());
    save_log_download();
  }
  write_summary(result.complete, reason);
  if (!reason.empty()) event(vehicle_.time(), "cut short: " + reason);
  firmware_.reset();
  if (station_) station_->finish();
  if (ground_cams_) ground_cams_->finish();
  return result;
}

}  // namespace

SessionResult run_session(const Scenario& scenario, const SessionOptions& options) {
  Session session(scenario, options);
  return session.run();
}

}  // namespace quad::sim
