// The world around one FlightApp for in-process tests: storage, clock, and everything it sends, decoded.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "quad/firmware/app.h"
#include "quad/firmware/hil_bridge.h"

namespace quad {
namespace fw {
namespace test {

namespace mav = ::quad::mavlink;
using ::quad::fw::FlightMode;

constexpr float kG = 9.80665f;

// A vehicle that moves only vertically (level, heading north) under the four rotor thrusts
// f_i = f_max u_i^2 (control/vehicle.h), standing on the ground at z = 0;
// the airframe of the default parameters (1.4 kg, 880 g per motor).
struct VerticalVehicle {
  float z = 0.0f, vz = 0.0f;
  float f_max = 0.880f * kG, mass = 1.4f;
  // Integrates one step of dt; returns the specific force along body z the accelerometer reads.
  float step(const float (&u)[16], float dt) {
    float thrust = 0.0f;
    for (int i = 0; i < 4; ++i) thrust += f_max * u[i] * u[i];
    float az = kG - thrust / mass;
    if (z >= 0.0f && az > 0.0f) az = 0.0f;  // the ground holds it
    vz += az * dt;
    z += vz * dt;
    if (z > 0.0f) {
      z = 0.0f;
      vz = 0.0f;
    }
    const bool on_ground = z >= 0.0f && vz == 0.0f;
    return on_ground ? -kG : -thrust / mass;
  }
};

// The world around one FlightApp: storage, clock, and everything it sends, decoded.
class Bench {
 public:
  Bench() : storage(4096, 0xFF) { current = this; }
  ~Bench() { current = nullptr; }

  void boot(bool hil = true) {
    app = std::make_unique<quad::fw::FlightApp>();
    quad::fw::AppIo io;
    io.storage = quad::fw::StorageIo{&Bench::storage_read, &Bench::storage_write};
    io.write = &Bench::write;
    io.micros = &Bench::micros;
    io.log_store = log_store;
    if (hil) {
      bridge = std::make_unique<quad::fw::HilBridge>();
      bridge->connect(*app, io);
    }
    app->init(io);
  }

  // One HIL step of a vehicle with attitude q, body rate w, specific force f_b (FRD).
  void hil_step(const Eigen::Quaternionf& q, const Eigen::Vector3f& f_b, const Eigen::Vector3f& w_b = Eigen::Vector3f::Zero()) {
    const Eigen::Vector3f m_b = mag_distortion * (q.conjugate() * mag_ned) + mag_hard_iron;  // thesis eq. 7.5
    mav::HilSensor s;
    s.time_usec = t_us;
    s.xacc = f_b.x() + accel_bias.x();
    s.yacc = f_b.y() + accel_bias.y();
    s.zacc = f_b.z() + accel_bias.z();
    s.xgyro = w_b.x() + gyro_bias.x();
    s.ygyro = w_b.y() + gyro_bias.y();
    s.zgyro = w_b.z() + gyro_bias.z();
    s.xmag = m_b.x();
    s.ymag = m_b.y();
    s.zmag = m_b.z();
    s.fields_updated = 0x1FF;
    send(quad::hal::kUart0, s, sim);
    t_us += step_us;
  }
  void still_step(const Eigen::Quaternionf& q = Eigen::Quaternionf::Identity()) {
    hil_step(q, q.conjugate() * Eigen::Vector3f(0, 0, -kG));
  }

  template <class Msg>
  void send(uint8_t port, const Msg& msg, mav::Sender& from) {
    uint8_t buf[mav::max_frame_length<Msg>()];
    const size_t n = from.encode(msg, buf, sizeof buf);
    app->receive(port, buf, static_cast<uint16_t>(n), static_cast<uint32_t>(t_us));
  }
  // The frame's bytes too, so a test can replay them.
  template <class Msg>
  std::vector<uint8_t> send_signed(uint8_t port, const Msg& msg, mav::Sender& from, mav::Signer& signer) {
    uint8_t buf[mav::max_frame_length<Msg>(true)];
    const size_t n = mav::encode_signed(from, signer, msg, buf, sizeof buf);
    EXPECT_GT(n, 0u);
    app->receive(port, buf, static_cast<uint16_t>(n), static_cast<uint32_t>(t_us));
    return std::vector<uint8_t>(buf, buf + n);
  }
  void receive_bytes(uint8_t port, const std::vector<uint8_t>& bytes) {
    app->receive(port, bytes.data(), static_cast<uint16_t>(bytes.size()), static_cast<uint32_t>(t_us));
  }

  // PARAM_SET of one parameter (REAL32), as a ground station sends it; the answer lands in `params`.
  void set_param(const char* name, float value, uint8_t port = quad::hal::kUart0) {
    mav::ParamSet set;
    set.target_system = 1;
    set.param_type = mav::kParamTypeReal32;
    std::strncpy(set.param_id, name, 16);
    set.param_value = value;
    send(port, set, gcs);
  }

  void sticks(int16_t throttle, uint16_t buttons = 0) {
    mav::ManualControl m;
    m.target = 1;
    m.z = throttle;
    m.buttons = buttons;
    send(quad::hal::kUart0, m, gcs);
  }

  uint8_t command(uint16_t cmd, float p1 = 0.0f, float p2 = 0.0f) {
    mav::CommandLong c;
    c.command = cmd;
    c.param1 = p1;
    c.param2 = p2;
    c.target_system = 1;
    c.target_component = 1;
    const size_t before = acks.size();
    send(quad::hal::kUart0, c, gcs);
    EXPECT_EQ(acks.size(), before + 1) << "every command is acknowledged";
    return acks.empty() ? 255 : acks.back().result;
  }
  uint8_t arm() { return command(mav::kCmdComponentArmDisarm, 1.0f); }
  // A SET_POSITION_TARGET_LOCAL_NED with the position only (velocity, acceleration, yaw and yaw rate
  // ignored), straight above the origin at NED z.
  void position_target(float z) {
    mav::SetPositionTargetLocalNed sp;
    sp.target_system = 1;
    sp.coordinate_frame = mav::kFrameLocalNed;
    sp.type_mask = 0x38 | 0x1C0 | 0x800 | 0x400;
    sp.z = z;
    send(quad::hal::kUart0, sp, gcs);
  }
  uint8_t set_mode(FlightMode m) { return command(mav::kCmdDoSetMode, 1.0f, static_cast<float>(m)); }

  // The star seen from a vehicle at p (NED) with attitude q, as the vision station reports it.
  void landing_target(const Eigen::Vector3f& p, const Eigen::Quaternionf& q, uint64_t capture_us,
                      const Eigen::Vector3f& star = Eigen::Vector3f::Zero()) {
    const Eigen::Vector3f p_b = q.conjugate() * (star - p);
    mav::LandingTarget lt;
    lt.time_usec = capture_us;
    lt.frame = mav::kFrameBodyFrd;
    lt.position_valid = 1;
    lt.x = p_b.x();
    lt.y = p_b.y();
    lt.z = p_b.z();
    send(quad::hal::kUart2, lt, vision);
  }

  bool said(const std::string& needle) const {
    return std::any_of(texts.begin(), texts.end(), [&](const std::string& t) { return t.find(needle) != std::string::npos; });
  }

  std::unique_ptr<quad::fw::FlightApp> app;
  std::unique_ptr<quad::fw::HilBridge> bridge;
  std::vector<uint8_t> storage;
  bool storage_fails = false;
  uint64_t t_us = 1000000;
  uint32_t step_us = 10000;  // HIL period: 100 Hz unless a test sets SYS_LOOP_HZ and this together
  Eigen::Vector3f gyro_bias{0.02f, -0.015f, 0.01f};
  Eigen::Vector3f accel_bias{0.15f, -0.1f, 0.2f};
  // The magnetometer: Earth field (NED, gauss), soft iron D and hard iron b (thesis eq. 7.5).
  Eigen::Vector3f mag_ned{0.21f, 0.0f, 0.43f};
  Eigen::Matrix3f mag_distortion = Eigen::Matrix3f::Identity();
  Eigen::Vector3f mag_hard_iron = Eigen::Vector3f::Zero();
  mav::Sender sim{1, 200};
  mav::Sender gcs{255, 190};
  mav::Sender vision{1, 197};
  mav::Parser out[quad::hal::kPortCount];
  std::vector<std::string> texts;
  // Every STATUSTEXT (one copy) with its severity, apart from `texts` (which tests may clear).
  std::vector<std::pair<uint8_t, std::string>> statustexts;
  std::vector<mav::CommandAck> acks;
  std::vector<mav::ParamValue> params;
  std::vector<mav::HilActuatorControls> actuators;
  int frames_on[quad::hal::kPortCount] = {0, 0};
  int signed_frames_on[quad::hal::kPortCount] = {0, 0};
  std::vector<mav::SysStatus> statuses;
  std::vector<std::pair<uint8_t, mav::LogEntry>> log_entries;
  std::vector<std::pair<uint8_t, mav::LogData>> log_data;
  const quad::fw::LogStore* log_store = nullptr;  // set before boot()
  std::vector<mav::ExtendedSysState> extended_states;  // UART0's
  std::vector<mav::EstimatorStatus> estimator_statuses;  // UART0's
  // Frames the vehicle sent, by port and message id.
  std::map<uint32_t, int> messages_on[quad::hal::kPortCount];
  int count_on(uint8_t port, uint32_t message_id) const {
    const auto it = messages_on[port].find(message_id);
    return it == messages_on[port].end() ? 0 : it->second;
  }
  // The execution time of one control iteration as the application measures it: each read of the
  // iteration clock (AppIo::micros, read at the start and the end of an iteration) advances it by this
  // much beyond the HIL time. 0 (the default): iterations take no time.
  uint32_t exec_us = 0;
  // When set, every frame the vehicle sends on the radio is checked as a ground station would.
  mav::SignatureVerifier* radio_verifier = nullptr;
  mav::SignatureCheck last_radio_check = mav::SignatureCheck::kAcceptedUnsigned;
  mav::Timesync timesync;
  bool have_timesync = false;
  bool last_timesync(mav::Timesync* out) const {
    *out = timesync;
    return have_timesync;
  }

 private:
  static inline Bench* current = nullptr;
  static bool storage_read(uint16_t offset, void* dst, uint16_t length) {
    if (current->storage_fails || offset + length > current->storage.size()) return false;
    std::memcpy(dst, current->storage.data() + offset, length);
    return true;
  }
  static bool storage_write(uint16_t offset, const void* src, uint16_t length) {
    if (current->storage_fails || offset + length > current->storage.size()) return false;
    std::memcpy(current->storage.data() + offset, src, length);
    return true;
  }
  static uint32_t micros() {
    const uint32_t now = static_cast<uint32_t>(current->t_us) + current->exec_offset_us_;
    current->exec_offset_us_ += current->exec_us;
    return now;
  }
  uint32_t exec_offset_us_ = 0;
  static uint16_t write(uint8_t port, const uint8_t* data, uint16_t length) {
    current->out[port].feed(data, length, [port](const mav::Frame& f) { current->on_frame(port, f); });
    return length;
  }
  void on_frame(uint8_t port, const mav::Frame& f) {
    ++frames_on[port];
    ++messages_on[port][f.message_id];
    if (f.is_signed()) ++signed_frames_on[port];
    if (radio_verifier != nullptr && port == quad::hal::kUart2) last_radio_check = radio_verifier->check(f);
    mav::Statustext text;
    mav::CommandAck ack;
    mav::ParamValue pv;
    mav::HilActuatorControls act;
    // STATUSTEXT goes to both ports; keep one copy.
    if (mav::decode(f, text) && port == quad::hal::kUart0) {
      texts.emplace_back(text.text, strnlen(text.text, 50));
      statustexts.emplace_back(text.severity, texts.back());
    }
    if (mav::decode(f, ack)) acks.push_back(ack);
    if (mav::decode(f, pv)) params.push_back(pv);
    if (mav::decode(f, act)) actuators.push_back(act);
    mav::SysStatus st;
    if (mav::decode(f, st)) statuses.push_back(st);
    mav::LogEntry entry;
    if (mav::decode(f, entry)) log_entries.emplace_back(port, entry);
    mav::LogData data;
    if (mav::decode(f, data)) log_data.emplace_back(port, data);
    mav::ExtendedSysState ext;
    if (mav::decode(f, ext) && port == quad::hal::kUart0) extended_states.push_back(ext);
    mav::EstimatorStatus est;
    if (mav::decode(f, est) && port == quad::hal::kUart0) estimator_statuses.push_back(est);
    mav::Timesync ts;
    if (mav::decode(f, ts)) {
      timesync = ts;
      have_timesync = true;
    }
  }
};

// Still steps until the estimator's pre-arm check passes (the thesis pair's ground hold starts 0.5 s
// after the calibration; StateEstimator::preflight()).
inline void ready_to_arm(Bench& b) {
  for (int i = 0; i < 2000 && b.app->estimator().preflight() != Preflight::kReady; ++i) b.still_step();
  ASSERT_EQ(b.app->estimator().preflight(), Preflight::kReady);
}

// A VerticalVehicle flown by the bench's firmware in HIL, level and heading north, at the bench's step
// period: a vision fix of its true height every 30 ms (captured at the step) and neutral sticks every
// 50 ms, counted from the first step of each fly().
struct VerticalFlight {
  explicit VerticalFlight(Bench& bench) : b(bench) {}
  // One step; `rate` is the body rate the gyro reads, `inputs` false leaves out the fix and the sticks.
  void step(int i, const Eigen::Vector3f& rate = Eigen::Vector3f::Zero(), bool inputs = true) {
    b.hil_step(Eigen::Quaternionf::Identity(), Eigen::Vector3f(0, 0, f_z), rate);
    f_z = v.step(b.actuators.back().controls, 1e-6f * static_cast<float>(b.step_us));
    if (!inputs) return;
    const int per_10ms = static_cast<int>(10000u / b.step_us);
    if (i % (3 * per_10ms) == 0) b.landing_target(Eigen::Vector3f(0, 0, v.z), Eigen::Quaternionf::Identity(), b.t_us - b.step_us);
    if (i % (5 * per_10ms) == 0) b.sticks(0);
  }
  void fly(int steps) {
    for (int i = 0; i < steps; ++i) step(i);
  }
  void fly_seconds(float seconds) { fly(static_cast<int>(seconds * 1e6f / static_cast<float>(b.step_us) + 0.5f)); }

  Bench& b;
  VerticalVehicle v;
  float f_z = -kG;  // the accelerometer's z reading of the last step
};

// Bench::set_param, and the firmware's PARAM_VALUE answer holding the new value.
inline void set_param_echoed(Bench& b, const char* name, float value) {
  b.set_param(name, value);
  ASSERT_FALSE(b.params.empty());
  ASSERT_FLOAT_EQ(b.params.back().param_value, value) << name;
}

}  // namespace test
}  // namespace fw
}  // namespace quad
