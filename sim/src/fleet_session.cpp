#include "quad/sim/fleet_session.h"

#include <poll.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "quad/link/dialect.h"
#include "quad/link/mavlink.h"
#include "quad/sim/firmware_process.h"
#include "quad/sim/fix_source.h"
#include "quad/sim/fleet_model.h"
#include "quad/sim/fleet_world.h"
#include "quad/sim/frames.h"
#include "quad/sim/ground_ids.h"
#include "quad/sim/hil_messages.h"
#include "quad/sim/imu.h"
#include "quad/sim/magnetometer.h"
#include "quad/sim/metrics.h"
#include "quad/sim/progress_pace.h"
#include "quad/sim/pty.h"
#include "quad/sim/run_output.h"
#include "quad/sim/serial_line.h"
#include "quad/sim/udp_link.h"

namespace quad::sim {
namespace mav = quad::mavlink;

namespace {

using Clock = std::chrono::steady_clock;

const std::vector<std::string>& fleet_log_columns() {
  static const std::vector<std::string> c = {
      "t", "true_n", "true_e", "true_d", "true_vn", "true_ve", "true_vd", "true_roll", "true_pitch", "true_yaw",
      "est_n", "est_e", "est_d", "sp_n", "sp_e", "sp_d", "cmd0", "cmd1", "cmd2", "cmd3", "mode", "armed",
      "vision_sent", "nearest_m"};
  return c;
}

// CPU seconds (user + system) a live process has used, from /proc/PID/stat; -1 when unreadable.
double process_cpu_s(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t close = text.rfind(')');
  if (close == std::string::npos) return -1.0;
  std::istringstream fields(text.substr(close + 2));
  std::string f;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && fields >> f; ++i) {  // fields 14 and 15: utime, stime (clock ticks)
    if (i == 14) utime = std::stoull(f);
    if (i == 15) stime = std::stoull(f);
  }
  return static_cast<double>(utime + stime) / static_cast<double>(sysconf(_SC_CLK_TCK));
}

double self_cpu_s() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double load_1min() {
  double l = -1.0;
  if (std::FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf", &l) != 1) l = -1.0;
    std::fclose(f);
  }
  return l;
}

// One vehicle's side of the run: its sensors, links, firmware process, schedule and figures.
struct Craft {
  Craft(const Scenario& s, const FleetVehicle& v, size_t i, const std::string& out_dir, double ground_down)
      : spec(v),
        index(i),
        dir(out_dir + "/" + v.name),
        imu(s.imu, Rng(s.seed, "imu/" + v.name)),
        mag(s.mag, Rng(s.seed, "magnetometer/" + v.name)),
        uart0(s.uart0_baud),
        uart2(s.radio_baud),
        uart0_out(s.uart0_baud, Rng(s.seed, "uart0/" + v.name)),
        radio_up(s.radio_baud, Rng(s.seed, "radio_up/" + v.name)),
        radio_down(s.radio_baud, Rng(s.seed, "radio_down/" + v.name)),
        ids(static_cast<uint8_t>(v.system_id)),
        metrics(FlightMetricsConfig{s.hold_start_s, s.hold_end_s, s.extra_holds, s.settle_band_m, 1.05, 2.0, ground_down}) {
    radio_up.set_radio(s.radio);
    radio_down.set_radio(s.radio);
  }
  const FleetVehicle& spec;
  size_t index;
  std::string dir;
  Mpu6000 imu;
  Hmc5883l mag;
  ImuReading imu_reading{};
  bool mag_fresh = false;
  Pty uart0, uart2;
  SerialLine uart0_out, radio_up, radio_down;
  mav::Sender sensor_sender{kVehicleSys, kSimComp};
  mav::Sender gcs_sender{kGcsSys, mav::kCompIdMissionPlanner};
  mav::Parser uart0_parser, uart2_splitter;
  mav::Parser ground_parser{mav::dialect_message_info};
  std::unique_ptr<UdpLink> udp;
  GroundIds ids;  // the vehicle as system_id at its UDP port
  mav::Parser udp_parser{mav::dialect_message_info};
  std::unique_ptr<FirmwareProcess> firmware;
  std::unique_ptr<CsvLog> log;
  // Schedule and exchange.
  size_t next_command = 0;
  std::optional<Eigen::Vector3d> setpoint;
  double setpoint_time = -1.0;
  std::deque<std::pair<double, std::array<double, 4>>> pending;
  std::optional<mav::HilActuatorControls> answer;
  uint64_t awaited_usec = 0;
  bool radio_written = false, spoke = false;
  double next_rc_t = 0.0;
  std::vector<uint8_t> last_sensor_frame;
  // The firmware's view (telemetry on UART0).
  Eigen::Vector3d est = Eigen::Vector3d::Constant(NAN);
  HeartbeatState heartbeat;
  // Figures.
  FlightMetrics metrics;
  ErrorStats tracking;     // 3-D distance from the truth to the setpoint within the metrics window, armed
  ErrorStats estimate;     // horizontal distance from the estimate to the truth of the same row, armed
  double nearest_m = INFINITY;  // to the nearest other vehicle, whole run
  double firmware_cpu_s = 0.0;
  bool answered() const { return answer && answer->time_usec == awaited_usec; }
};

class FleetSession {
 public:
  FleetSession(const Scenario& s, const SessionOptions& o);
  ~FleetSession() {
    if (events_) std::fclose(events_);
  }
  SessionResult run();

 private:
  void event(double t, const Craft& c, const std::string& text);
  template <class Msg>
  void send_gcs(Craft& c, const Msg& msg, double t);
  void send_due_commands(Craft& c, double t);
  void send_sensors(Craft& c, double t);
  void send_rc(Craft& c, double t);
  void sample_sensors(Craft& c);
  void handle_frame(Craft& c, const mav::Frame& f, double t, bool uart0);
  void poll_uart0(Craft& c, double t);
  void radio_uplink(Craft& c, const uint8_t* d, size_t n, double t) { c.radio_up.send(d, n, t); }
  void start_processes();
  void wait_radio_consumed(Craft& c);
  std::string exchange(double t, double period, double byte_s);
  void physics_period(double t_end);
  void log_rows(double t);
  void write_summary(bool complete, const std::string& reason);
  void progress(double t, bool final_line);

  const Scenario& s_;
  const SessionOptions& o_;
  std::unique_ptr<FleetWorld> world_;
  std::vector<std::unique_ptr<Craft>> crafts_;
  std::vector<std::unique_ptr<FixSource>> fixes_;
  std::FILE* events_ = nullptr;
  Eigen::Vector3d field_ned_;
  uint64_t exchanges_ = 0;
  double min_separation_m_ = INFINITY, min_separation_t_ = 0.0;
  size_t min_pair_a_ = 0, min_pair_b_ = 0;
  double load_start_ = -1.0, cpu_start_ = 0.0;
  double station_cpu_s_ = 0.0;  // the ground-camera station's process, last read
  Clock::time_point wall_start_, last_summary_;
  ProgressPace progress_pace_;
};

FleetSession::FleetSession(const Scenario& s, const SessionOptions& o) : s_(s), o_(o), field_ned_(s.field_ned_gauss) {
  make_directories(o.out_dir);
  events_ = std::fopen((o.out_dir + "/events.log").c_str(), "w");
  if (!events_) throw std::runtime_error(o.out_dir + "/events.log: cannot create");
  const std::string model = o.out_dir + "/fleet_model.xml";
  write_file_atomically(model, fleet_model_xml(s.model_path, s.vehicles));
  VehicleParams p;
  p.model_path = model;
  p.motor = s.motor;
  p.drag_linear_n_per_m_s = s.drag_linear;
  p.drag_quadratic_n_per_m2_s2 = s.drag_quadratic;
  world_ = std::make_unique<FleetWorld>(p, s.vehicles);
  world_->start(s.vehicles, 0.5);
  FixSourceContext context;
  context.out_dir = o.out_dir;
  context.station_argv = o.station_argv;
  context.room_calibration = o.room_calibration;
  context.calibration_cache = o.station_calibration_cache;
  context.progress = [this](const std::string& line) {
    if (o_.progress) std::fprintf(stderr, "%s\n", line.c_str());
  };
  for (size_t i = 0; i < s.vehicles.size(); ++i) context.start.push_back(world_->truth(i));
  fixes_ = make_fix_sources(s, context);
  for (size_t i = 0; i < s.vehicles.size(); ++i) {
    auto c = std::make_unique<Craft>(s, s.vehicles[i], i, o.out_dir, world_->rest_down_m());
    make_directories(c->dir);
    c->log = std::make_unique<CsvLog>(c->dir + "/log.csv", fleet_log_columns());
    if (o.gcs_udp) {
      UdpEndpoint to = *o.gcs_udp;
      to.port += static_cast<int>(i);
      c->udp = std::make_unique<UdpLink>(to);
    }
    crafts_.push_back(std::move(c));
  }
  for (auto& c : crafts_) sample_sensors(*c);
}

void FleetSession::event(double t, const Craft& c, const std::string& text) {
  std::fprintf(events_, "%9.3f %s: %s\n", t, c.spec.name.c_str(), text.c_str());
  std::fflush(events_);
}

template <class Msg>
void FleetSession::send_gcs(Craft& c, const Msg& msg, double t) {
  uint8_t buf[mav::max_frame_length<Msg>()];
  const size_t n = c.gcs_sender.encode(msg, buf, sizeof buf);
  if (s_.gcs_over_radio) radio_uplink(c, buf, n, t);
  else c.uart0_out.send(buf, n, t);
}

void FleetSession::send_due_commands(Craft& c, double t) {
  const auto& commands = c.spec.commands;
  while (c.next_command < commands.size() && commands[c.next_command].at_s <= t + 1e-9) {
    const GcsCommand& g = commands[c.next_command++];
    if (g.setpoint_ned_m) {
      send_gcs(c, setpoint_message(g, t), t);
      c.setpoint = g.setpoint_ned_m;
      c.setpoint_time = t;
      continue;
    }
    const CommandMessage cmd = command_long_message(g);
    send_gcs(c, cmd.message, t);
    event(t, c, "gcs: " + cmd.what);
  }
}

// The RC link's frames (sticks centred, throttle down: the firmware refuses to arm without an RC link).
void FleetSession::send_rc(Craft& c, double t) {
  if (t + 1e-9 < c.next_rc_t) return;
  c.next_rc_t += 1.0 / s_.rc_rate_hz;
  mav::ManualControl mc;
  mc.target = kVehicleSys;
  uint8_t buf[mav::max_frame_length<mav::ManualControl>()];
  c.uart0_out.send(buf, c.gcs_sender.encode(mc, buf, sizeof buf), t);
}

void FleetSession::sample_sensors(Craft& c) {
  const VehicleTruth truth = world_->truth(c.index);
  c.imu_reading = c.imu.sample(truth.specific_force_frd, truth.rate_frd, world_->mean_speed_fraction(c.index));
  if (s_.mag.present && c.mag.update(world_->time(), truth.q_ib.conjugate() * field_ned_)) c.mag_fresh = true;
}

void FleetSession::send_sensors(Craft& c, double t) {
  const mav::HilSensor m = hil_sensor_message(t, c.imu_reading, c.mag.reading(), c.mag_fresh);
  c.mag_fresh = false;
  uint8_t buf[mav::max_frame_length<mav::HilSensor>()];
  const size_t n = c.sensor_sender.encode(m, buf, sizeof buf);
  c.last_sensor_frame.assign(buf, buf + n);
  c.uart0_out.send(buf, n, t);
}

void FleetSession::handle_frame(Craft& c, const mav::Frame& f, double t, bool uart0) {
  if (f.system_id != kVehicleSys || f.component_id != mav::kCompIdAutopilot1) return;
  c.spoke = true;
  if (!uart0 && f.message_id != mav::Statustext::kId && f.message_id != mav::CommandAck::kId) return;
  switch (f.message_id) {
    case mav::HilActuatorControls::kId: {
      mav::HilActuatorControls m;
      if (mav::decode(f, m)) c.answer = m;
      break;
    }
    case mav::Heartbeat::kId: {
      mav::Heartbeat m;
      if (mav::decode(f, m) && c.heartbeat.update(m)) event(t, c, "firmware: " + c.heartbeat.text());
      break;
    }
    case mav::LocalPositionNed::kId: {
      mav::LocalPositionNed m;
      if (mav::decode(f, m)) c.est = {m.x, m.y, m.z};
      break;
    }
    case mav::Statustext::kId: {
      mav::Statustext m;
      if (mav::decode(f, m)) event(t, c, std::string("firmware: ") + std::string(m.text, strnlen(m.text, sizeof m.text)));
      break;
    }
    case mav::CommandAck::kId: {
      mav::CommandAck m;
      if (mav::decode(f, m))
        event(t, c, "firmware: COMMAND_ACK " + std::to_string(m.command) + " result " + std::to_string(m.result));
      break;
    }
    default: break;
  }
}

void FleetSession::poll_uart0(Craft& c, double t) {
  uint8_t buf[4096];
  for (size_t n; (n = c.uart0.read_some(buf, sizeof buf)) > 0;)
    c.uart0_parser.feed(buf, n, [&](const mav::Frame& f) { handle_frame(c, f, t, true); });
}

// Each vehicle's parameter file (HIL_LOCKSTEP 1 unless the scenario sets it), then every firmware
// process; then each one's hello (its STATUSTEXT) and 100 ms of quiet, as the single-vehicle run waits.
void FleetSession::start_processes() {
  for (auto& c : crafts_) {
    std::string params = "# firmware parameters of this run (quad_sim, scenario " + s_.name + ", vehicle " + c->spec.name + ")\n";
    bool lockstep_set = false;
    for (const auto& [name, value] : c->spec.firmware_params) {
      char line[96];
      std::snprintf(line, sizeof line, "%s %.9g\n", name.c_str(), value);
      params += line;
      lockstep_set = lockstep_set || name == "HIL_LOCKSTEP";
    }
    if (!lockstep_set) params += "HIL_LOCKSTEP 1\n";
    write_file_atomically(c->dir + "/firmware_params.txt", params);
    std::vector<std::string> argv = o_.firmware_argv;
    for (size_t k = 0; k + 1 < argv.size(); ++k)
      if (argv[k] == "--log-dir") argv[k + 1] = c->dir;  // each vehicle's flight logs in its own folder
    for (const std::string& a : {std::string("--uart0"), c->uart0.slave_path(), std::string("--uart0-baud"),
                                 std::to_string(s_.uart0_baud), std::string("--uart2"), c->uart2.slave_path(),
                                 std::string("--uart2-baud"), std::to_string(s_.radio_baud), std::string("--params"),
                                 c->dir + "/firmware_params.txt"})
      argv.push_back(a);
    std::string cmd;
    for (const auto& a : argv) cmd += (cmd.empty() ? "" : " ") + a;
    event(0.0, *c, "start: " + cmd);
    if (c->udp) event(0.0, *c, "gcs udp: local port " + std::to_string(c->udp->local_port()) + ", sending to " + c->udp->peer());
    c->firmware = std::make_unique<FirmwareProcess>(argv, c->dir + "/firmware.log");
  }
  const auto deadline = Clock::now() + std::chrono::milliseconds(1500);
  for (auto& c : crafts_) {
    while (Clock::now() < deadline && c->firmware->running()) {
      if (c->uart0.wait_readable(100)) poll_uart0(*c, 0.0);
      else if (c->spoke) break;
    }
  }
}

// Radio bytes handed over after the last answer must be read before this step's HIL_SENSOR (as in the
// single-vehicle run, hil_session.cpp): wait until UART2's queue is empty, 200 ms at most.
void FleetSession::wait_radio_consumed(Craft& c) {
  if (!c.radio_written) return;
  c.radio_written = false;
  const auto start = Clock::now();
  while (c.uart2.unread_by_peer() > 0 && Clock::now() - start < std::chrono::milliseconds(200))
    std::this_thread::sleep_for(std::chrono::microseconds(50));
}

// Every vehicle gets its HIL_SENSOR, then every answer is awaited (the firmware processes run in
// parallel). The commands take effect when the answer's last byte has crossed UART0 in simulated time.
std::string FleetSession::exchange(double t, double period, double byte_s) {
  for (auto& c : crafts_) {
    c->answer.reset();
    c->awaited_usec = to_usec(t);
    c->uart0_out.deliver_until(1e18, [&](const uint8_t* d, size_t n) { c->uart0.write_all(d, n); });
  }
  const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(o_.answer_timeout_s));
  auto next_resend = Clock::now() + std::chrono::milliseconds(250);
  std::vector<pollfd> fds;
  std::vector<Craft*> waiting;
  for (;;) {
    fds.clear();
    waiting.clear();
    for (auto& c : crafts_) {
      if (c->answered()) continue;
      if (!c->firmware->running()) return c->spec.name + ": the firmware " + c->firmware->status() + " (see its firmware.log)";
      fds.push_back({c->uart0.master_fd(), POLLIN, 0});
      waiting.push_back(c.get());
    }
    if (waiting.empty()) break;
    const auto now = Clock::now();
    if (now >= deadline)
      return waiting.front()->spec.name + ": the firmware did not answer HIL_SENSOR at t = " + std::to_string(t) + " s";
    if (exchanges_ == 0 && now >= next_resend) {  // a firmware still opening its port (see hil_session.cpp)
      for (Craft* c : waiting)
        if (!c->spoke) c->uart0.write_all(c->last_sensor_frame.data(), c->last_sensor_frame.size());
      next_resend = now + std::chrono::milliseconds(250);
    }
    if (::poll(fds.data(), fds.size(), 100) <= 0) continue;
    for (size_t k = 0; k < fds.size(); ++k)
      if (fds[k].revents & (POLLIN | POLLHUP | POLLERR)) poll_uart0(*waiting[k], t);
  }
  ++exchanges_;
  for (auto& c : crafts_) {
    std::array<double, 4> cmd;
    for (size_t i = 0; i < 4; ++i) cmd[i] = c->answer->controls[i];
    const double sent = std::max(t, c->uart0_out.busy_until());
    c->pending.emplace_back(sent + byte_s * static_cast<double>(mav::max_frame_length<mav::HilActuatorControls>()), cmd);
    c->radio_up.deliver_until(t + period, [&](const uint8_t* d, size_t n) {
      c->uart2.write_all(d, n);
      c->radio_written = true;
      for (auto& src : fixes_) src->delivered(c->index, t + period, d, n);
    });
  }
  return "";
}

void FleetSession::physics_period(double t_end) {
  const double dt = world_->timestep();
  std::vector<VehicleTruth> truth(crafts_.size());
  while (world_->time() < t_end - 0.5 * dt) {
    const double t = world_->time();
    for (auto& c : crafts_) {
      while (!c->pending.empty() && t + 1e-9 >= c->pending.front().first) {
        world_->set_commands(c->index, c->pending.front().second);
        c->pending.pop_front();
      }
    }
    world_->set_wind_ned(s_.wind_at(t));
    const size_t collisions_before = world_->collisions().size();
    world_->step();
    const double now = world_->time();
    for (size_t k = collisions_before; k < world_->collisions().size(); ++k) {
      const Collision& col = world_->collisions()[k];
      event(now, *crafts_[col.a], "collision with " + crafts_[col.b]->spec.name);
    }
    for (auto& c : crafts_) {
      sample_sensors(*c);
      truth[c->index] = world_->truth(c->index);
    }
    for (size_t a = 0; a < truth.size(); ++a)
      for (size_t b = a + 1; b < truth.size(); ++b) {
        const double d = (truth[a].position_ned - truth[b].position_ned).norm();
        crafts_[a]->nearest_m = std::min(crafts_[a]->nearest_m, d);
        crafts_[b]->nearest_m = std::min(crafts_[b]->nearest_m, d);
        if (d < min_separation_m_) min_separation_m_ = d, min_separation_t_ = now, min_pair_a_ = a, min_pair_b_ = b;
      }
    for (auto& src : fixes_) {
      src->update(now, truth);
      src->release_until(now, [&](size_t i, double when, const uint8_t* d, size_t n) { radio_uplink(*crafts_[i], d, n, when); });
    }
    for (auto& c : crafts_) {
      c->radio_down.deliver_until(now, [&](const uint8_t* d, size_t n) {
        c->ground_parser.feed(d, n, [&](const mav::Frame& f) {
          uint8_t out[mav::kMaxFrameLength];
          if (c->udp)
            if (const size_t m = c->ids.to_ground(f, out, sizeof out)) c->udp->send(out, m);
          handle_frame(*c, f, now, false);
        });
      });
    }
  }
}

void FleetSession::log_rows(double t) {
  for (auto& c : crafts_) {
    const VehicleTruth tr = world_->truth(c->index);
    const Eigen::Vector3d e = euler_from_q_ib(tr.q_ib);
    const Eigen::Vector3d sp = c->setpoint ? *c->setpoint : Eigen::Vector3d::Constant(NAN);
    const auto& cmd = world_->commands(c->index);
    uint64_t sent = 0;
    for (const auto& src : fixes_) sent += src->released(c->index);
    double nearest = INFINITY;
    for (const auto& o : crafts_)
      if (o != c) nearest = std::min(nearest, (world_->truth(o->index).position_ned - tr.position_ned).norm());
    c->log->row({t, tr.position_ned.x(), tr.position_ned.y(), tr.position_ned.z(), tr.velocity_ned.x(), tr.velocity_ned.y(),
                 tr.velocity_ned.z(), e.x(), e.y(), e.z(), c->est.x(), c->est.y(), c->est.z(), sp.x(), sp.y(), sp.z(),
                 cmd[0], cmd[1], cmd[2], cmd[3], static_cast<double>(c->heartbeat.mode), c->heartbeat.armed ? 1.0 : 0.0,
                 static_cast<double>(sent), crafts_.size() > 1 ? nearest : NAN});
    const double tilt = std::acos(std::clamp((tr.q_ib * Eigen::Vector3d::UnitZ()).z(), -1.0, 1.0));
    c->metrics.add(t, tr.position_ned, tr.velocity_ned, tilt, c->setpoint, c->setpoint_time);
    if (c->heartbeat.armed && c->setpoint && t >= s_.hold_start_s && t <= s_.hold_end_s)
      c->tracking.add((tr.position_ned - *c->setpoint).norm());
    if (c->heartbeat.armed && c->est.allFinite()) c->estimate.add((c->est - tr.position_ned).head<2>().norm());
  }
}

Json stats_of(const ErrorStats& e) {
  Json j;
  j.add("mean", e.mean()).add("std", e.stddev()).add("rms", e.rms()).add("max_abs", e.max_abs());
  return j;
}

void FleetSession::write_summary(bool complete, const std::string& reason) {
  const double wall = std::chrono::duration<double>(Clock::now() - wall_start_).count();
  const double sim = world_->time();
  double firmware_cpu = 0.0;
  for (auto& c : crafts_) {
    if (c->firmware && c->firmware->running()) {
      const double cpu = process_cpu_s(c->firmware->pid());
      if (cpu >= 0.0) c->firmware_cpu_s = cpu;
    }
    firmware_cpu += c->firmware_cpu_s;
  }
  for (const auto& src : fixes_) {
    const int pid = src->helper_pid();
    const double used = pid > 0 ? process_cpu_s(pid) : -1.0;
    if (used >= 0.0) station_cpu_s_ = used;  // kept once the station has ended
  }
  const double sim_cpu = self_cpu_s() - cpu_start_;
  const double total = sim_cpu + firmware_cpu + station_cpu_s_;
  Json cpu;
  cpu.add("simulator_s", sim_cpu).add("firmware_s", firmware_cpu).add("station_s", station_cpu_s_).add("total_s", total)
      .add("per_sim_s", sim > 0 ? total / sim : 0.0)
      .add("per_vehicle_per_sim_s", sim > 0 ? total / sim / static_cast<double>(crafts_.size()) : 0.0);
  Json machine;
  machine.add("cores", static_cast<long>(sysconf(_SC_NPROCESSORS_ONLN))).add("load_1min_start", load_start_)
      .add("load_1min_end", load_1min());
  Json sep;
  if (crafts_.size() > 1) {
    sep.add("min_m", min_separation_m_).add("at_s", min_separation_t_)
        .add("pair", crafts_[min_pair_a_]->spec.name + " " + crafts_[min_pair_b_]->spec.name);
  }
  Json collisions;
  collisions.add("count", static_cast<long>(world_->collisions().size()));
  Json vehicles;
  bool crashed = false;
  for (auto& c : crafts_) {
    Json v, hold, horizontal;
    hold.add("start_s", s_.hold_start_s).add("end_s", s_.hold_end_s).add("samples", c->metrics.hold(0).count());
    hold.add("north", stats_of(c->metrics.hold(0))).add("east", stats_of(c->metrics.hold(1))).add("vertical", stats_of(c->metrics.hold(2)));
    horizontal.add("std_2d", c->metrics.horizontal_stddev()).add("rms", c->metrics.hold_horizontal().rms())
        .add("max", c->metrics.hold_horizontal().max_abs());
    hold.add("horizontal", horizontal);
    v.add("system_id", static_cast<long>(c->spec.system_id)).add("fix_source", fix_source_name(c->spec.fix_source));
    v.add("hold", hold).add("tracking_error_m", stats_of(c->tracking));
    v.add("estimate_horizontal_rms_m", c->estimate.rms());
    if (crafts_.size() > 1) v.add("nearest_vehicle_m", c->nearest_m);
    uint64_t sent = 0;
    for (const auto& src : fixes_) sent += src->released(c->index);
    v.add("fixes_sent", static_cast<long>(sent)).add("crashed", c->metrics.crashed());
    if (c->metrics.crashed()) v.add("crash_time_s", c->metrics.crash_time_s());
    v.add("armed_at_end", c->heartbeat.armed).add("mode_at_end", c->heartbeat.mode_name());
    if (c->udp) {
      const GroundIdStats& g = c->ids.stats();
      Json ids;
      ids.add("restamped", static_cast<long>(g.restamped)).add("readdressed", static_cast<long>(g.readdressed))
          .add("dropped", static_cast<long>(g.dropped)).add("signed_passed", static_cast<long>(g.signed_passed));
      v.add("gcs_udp_local_port", static_cast<long>(c->udp->local_port())).add("gcs_udp_peer", c->udp->peer())
          .add("gcs_udp_datagrams_received", static_cast<long>(c->udp->stats().datagrams_received)).add("ground_ids", ids);
    }
    v.add("firmware_cpu_s", c->firmware_cpu_s);
    for (const auto& src : fixes_) src->add_vehicle_summary(c->index, v);
    crashed = crashed || c->metrics.crashed();
    vehicles.add(c->spec.name, v);
  }
  Json j;
  j.add("scenario", s_.name).add("scenario_file", s_.path).add("seed", static_cast<long>(s_.seed));
  j.add("complete", complete);
  if (!complete) j.add("cut_short", reason);
  j.add("mode", o_.realtime ? "lockstep, paced by the wall clock" : "lockstep");
  j.add("vehicle_count", static_cast<long>(crafts_.size())).add("sim_time_s", sim).add("wall_time_s", wall);
  j.add("real_time_factor", wall > 0 ? sim / wall : 0.0).add("lockstep_exchanges", static_cast<long>(exchanges_));
  j.add("cpu", cpu).add("machine", machine);
  if (crafts_.size() > 1) j.add("separation", sep);
  j.add("collisions", collisions).add("crashed", crashed);
  for (const auto& src : fixes_) src->add_summary(j);
  j.add("vehicles", vehicles);
  write_file_atomically(o_.out_dir + "/summary.json", j.str() + "\n");
}

void FleetSession::progress(double t, bool final_line) {
  const auto now = Clock::now();
  if (!o_.progress || !progress_pace_.due(now, final_line)) return;
  const double wall = std::chrono::duration<double>(now - wall_start_).count();
  std::fprintf(stderr, "\r  t %6.1f / %.0f s | %6.2fx real time | %zu vehicles | nearest %5.2f m | collisions %zu%s", t,
               s_.duration_s, wall > 0 ? t / wall : 0.0, crafts_.size(), min_separation_m_, world_->collisions().size(),
               final_line ? "\n" : "");
  std::fflush(stderr);
}

SessionResult FleetSession::run() {
  load_start_ = load_1min();
  cpu_start_ = self_cpu_s();
  wall_start_ = last_summary_ = Clock::now();
  write_summary(false, "running");
  start_processes();
  for (auto& c : crafts_) sample_sensors(*c);
  wall_start_ = Clock::now();
  const double period = 1.0 / s_.control_rate_hz;
  const long periods = std::lround(s_.duration_s * s_.control_rate_hz);
  const double byte_s = 10.0 / s_.uart0_baud;
  std::string reason;
  uint8_t buf[2048];
  for (long k = 0; k < periods && reason.empty(); ++k) {
    const double t = static_cast<double>(k) * period;
    if (o_.stop && o_.stop->load()) {
      reason = "interrupted";
      break;
    }
    if (o_.realtime) {
      const double wall_t = std::chrono::duration<double>(Clock::now() - wall_start_).count();
      if (wall_t < t) std::this_thread::sleep_for(std::chrono::duration<double>(t - wall_t));
    }
    for (auto& c : crafts_) {
      wait_radio_consumed(*c);
      send_due_commands(*c, t);
      send_rc(*c, t);
      send_sensors(*c, t);
    }
    reason = exchange(t, period, byte_s);
    if (!reason.empty()) break;
    for (auto& c : crafts_) {
      // The firmware's radio output, frame by frame onto the radio; a ground station's datagrams onto the uplink.
      for (size_t n; (n = c->uart2.read_some(buf, sizeof buf)) > 0;)
        c->uart2_splitter.feed(buf, n, [&](const mav::Frame& f) { c->radio_down.send(f.bytes, f.size, t); });
      if (!c->udp) continue;
      for (size_t n; (n = c->udp->receive(buf, sizeof buf)) > 0;)
        c->udp_parser.feed(buf, n, [&](const mav::Frame& f) {
          uint8_t out[mav::kMaxFrameLength];
          if (const size_t m = c->ids.to_vehicle(f, out, sizeof out)) radio_uplink(*c, out, m, t);
        });
    }
    physics_period(t + period);
    log_rows(world_->time());
    progress(world_->time(), false);
    if (Clock::now() - last_summary_ > std::chrono::seconds(2)) {
      last_summary_ = Clock::now();
      write_summary(false, "running");
    }
  }
  SessionResult r;
  r.complete = reason.empty();
  r.reason = reason;
  r.sim_time_s = world_->time();
  r.wall_time_s = std::chrono::duration<double>(Clock::now() - wall_start_).count();
  for (auto& c : crafts_) r.crashed = r.crashed || c->metrics.crashed();
  progress(world_->time(), true);
  write_summary(r.complete, reason);  // reads the firmware processes' CPU time while they still run
  if (!reason.empty()) std::fprintf(events_, "%9.3f cut short: %s\n", world_->time(), reason.c_str());
  for (auto& src : fixes_) src->finish();
  write_summary(r.complete, reason);  // the station's last answers counted
  for (auto& c : crafts_) c->firmware.reset();
  return r;
}

}  // namespace

SessionResult run_fleet_session(const Scenario& scenario, const SessionOptions& options) {
  if (scenario.vehicles.empty()) throw std::invalid_argument(scenario.path + ": no vehicles: for a fleet run");
  FleetSession session(scenario, options);
  return session.run();
}

}  // namespace quad::sim
