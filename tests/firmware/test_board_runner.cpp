// The board loop (run_board / board_pass) on a fake HAL: this test defines the quad::hal functions the
// way a board target does (link-time selection), with a clock the test moves, sensors it fills and
// motors it records. The loop must run iterations on the SYS_LOOP_HZ grid, only with a new IMU sample,
// map the RC channels (roll, pitch, throttle, yaw), pass serial bytes to the application and drive the
// motors.
#include <gtest/gtest.h>

#include <cstring>
#include <deque>
#include <memory>
#include <vector>

#include "quad/firmware/runner.h"
#include "quad/hal/hal.h"

namespace {

namespace mav = quad::mavlink;

struct FakeBoard {
  uint32_t now_us = 0;
  std::deque<uint8_t> rx[quad::hal::kPortCount];
  std::vector<uint8_t> tx[quad::hal::kPortCount];
  std::vector<uint8_t> eeprom = std::vector<uint8_t>(4096, 0xFF);
  bool imu_new = true;
  quad::hal::ImuSample imu;
  bool rc_new = false;
  quad::hal::RcFrame rc{};
  std::vector<std::vector<float>> motor_writes;
  std::vector<bool> led;
  std::vector<quad::hal::TracePoint> trace;
};
FakeBoard* g_board = nullptr;

}  // namespace

// The fake target's HAL.
namespace quad {
namespace hal {
void init() {}
uint32_t micros() { return g_board->now_us; }
void idle(uint32_t max_wait_us) { g_board->now_us += max_wait_us; }
uint16_t serial_read(Port port, uint8_t* dst, uint16_t capacity) {
  uint16_t n = 0;
  while (n < capacity && !g_board->rx[port].empty()) {
    dst[n++] = g_board->rx[port].front();
    g_board->rx[port].pop_front();
  }
  return n;
}
uint16_t serial_write(Port port, const uint8_t* src, uint16_t length) {
  g_board->tx[port].insert(g_board->tx[port].end(), src, src + length);
  return length;
}
uint16_t serial_tx_free(Port) { return 0xFFFF; }
uint16_t storage_size() { return static_cast<uint16_t>(g_board->eeprom.size()); }
bool storage_read(uint16_t offset, void* dst, uint16_t length) {
  std::memcpy(dst, g_board->eeprom.data() + offset, length);
  return true;
}
bool storage_write(uint16_t offset, const void* src, uint16_t length) {
  std::memcpy(g_board->eeprom.data() + offset, src, length);
  return true;
}
void led_write(bool on) { g_board->led.push_back(on); }
void trace(TracePoint point) { g_board->trace.push_back(point); }
bool imu_read(ImuSample& out) {
  if (!g_board->imu_new) return false;
  out = g_board->imu;
  return true;
}
bool mag_read(MagSample& out) {
  out.field = Vec3{0.21f, 0.0f, 0.43f};
  return true;
}
bool rc_read(RcFrame& out) {
  if (!g_board->rc_new) return false;
  g_board->rc_new = false;
  out = g_board->rc;
  return true;
}
void motors_write(const float (&command)[kMotorCount]) {
  g_board->motor_writes.emplace_back(command, command + kMotorCount);
}
}  // namespace hal
}  // namespace quad

namespace {

class BoardRunner : public ::testing::Test {
 protected:
  void SetUp() override {
    g_board = &board_;
    board_.imu.accel = quad::Vec3{0.0f, 0.0f, -quad::kGravity};
    app_ = std::make_unique<quad::fw::FlightApp>();
    app_->init(quad::fw::hal_app_io());
  }
  void TearDown() override { g_board = nullptr; }

  // Runs the loop for `seconds` of board time, passes 1 ms apart (as if each pass took that long).
  int run_for(float seconds) {
    int iterations = 0;
    const uint32_t end = board_.now_us + static_cast<uint32_t>(seconds * 1e6f);
    while (static_cast<int32_t>(board_.now_us - end) < 0) {
      iterations += quad::fw::board_pass(*app_) ? 1 : 0;
      board_.now_us += 1000;
    }
    return iterations;
  }
  template <class Msg>
  void receive(uint8_t port, const Msg& msg) {
    uint8_t buf[mav::max_frame_length<Msg>()];
    const size_t n = gcs_.encode(msg, buf, sizeof buf);
    board_.rx[port].insert(board_.rx[port].end(), buf, buf + n);
  }
  void rc(uint16_t throttle, uint16_t enable = 1000, uint16_t auto_mode = 1000) {
    board_.rc.count = 8;
    for (uint16_t& p : board_.rc.pulse_us) p = 1500;
    board_.rc.pulse_us[quad::fw::kRcThrottle] = throttle;
    board_.rc.pulse_us[quad::fw::kRcMotorEnable] = enable;
    board_.rc.pulse_us[quad::fw::kRcAutoMode] = auto_mode;
    board_.rc_new = true;
  }
  // Throttle low on the RC for 50 ms, then an arm command on UART0 (it takes effect on the next pass).
  void send_arm() {
    rc(1000);
    run_for(0.05f);
    mav::CommandLong arm;
    arm.command = mav::kCmdComponentArmDisarm;
    arm.param1 = 1.0f;
    arm.target_system = 1;
    receive(quad::hal::kUart0, arm);
  }
  std::vector<mav::CommandAck> acks(uint8_t port) {
    std::vector<mav::CommandAck> out;
    mav::Parser parser;
    parser.feed(board_.tx[port].data(), board_.tx[port].size(), [&](const mav::Frame& f) {
      mav::CommandAck a;
      if (mav::decode(f, a)) out.push_back(a);
    });
    return out;
  }

  FakeBoard board_;
  std::unique_ptr<quad::fw::FlightApp> app_;
  mav::Sender gcs_{255, 190};
};

TEST_F(BoardRunner, IterationsFollowTheLoopRateGrid) {
  EXPECT_EQ(run_for(1.0f), 100) << "SYS_LOOP_HZ 100";
  EXPECT_EQ(board_.motor_writes.size(), 100u) << "the motors are written after every iteration";
  EXPECT_EQ(app_->loop_timer().overruns(), 0u);

  mav::ParamSet set;
  set.target_system = 1;
  std::strncpy(set.param_id, "SYS_LOOP_HZ", 16);
  set.param_value = 400.0f;
  receive(quad::hal::kUart0, set);
  run_for(0.01f);  // the PARAM_SET arrives
  EXPECT_NEAR(run_for(1.0f), 400, 1) << "SYS_LOOP_HZ 400: every 2.5 ms slot is met by a pass";
}

TEST_F(BoardRunner, LedBlinksFastWhileCalibratingSlowWhenReadyAndStaysOnWhenArmed) {
  auto toggles = [&](size_t from) {
    int n = 0;
    for (size_t i = from + 1; i < board_.led.size(); ++i) n += board_.led[i] != board_.led[i - 1] ? 1 : 0;
    return n;
  };
  run_for(1.0f);
  EXPECT_NEAR(toggles(0), 10, 1) << "5 Hz blink (100 ms on, 100 ms off) during calibration";
  run_for(1.5f);
  ASSERT_TRUE(app_->calibrated());
  size_t mark = board_.led.size();
  run_for(2.0f);
  EXPECT_NEAR(toggles(mark), 4, 1) << "1 Hz blink when ready";
  send_arm();
  run_for(0.05f);
  ASSERT_EQ(app_->mode(), quad::fw::FlightMode::kManual);
  mark = board_.led.size();
  run_for(0.5f);
  EXPECT_EQ(toggles(mark), 0);
  EXPECT_TRUE(board_.led.back());
}

TEST_F(BoardRunner, MotorEnableChannelArmsAndKills) {
  mav::ParamSet set;
  set.target_system = 1;
  std::strncpy(set.param_id, "RC_SWITCHES", 16);
  set.param_value = 1.0f;
  receive(quad::hal::kUart0, set);
  run_for(2.5f);
  ASSERT_TRUE(app_->calibrated());
  rc(1000, 1000);  // channel 5 (index 4) low
  run_for(0.05f);
  rc(1000, 2000);  // ... to high: arm
  run_for(0.05f);
  EXPECT_EQ(app_->mode(), quad::fw::FlightMode::kManual);
  rc(1000, 1000);  // ... and low again: disarm
  run_for(0.05f);
  EXPECT_EQ(app_->mode(), quad::fw::FlightMode::kDisarmed);
}

// avr_pil times the phases between these marks: every iteration must be bracketed, with its stages
// marked in order (estimator, mode machine, control marked once as flown, a motor command computed, or
// idle, disarmed; landing and telemetry) and nothing else inside.
TEST_F(BoardRunner, EveryIterationIsBracketedByTraceMarks) {
  using quad::hal::TracePoint;
  run_for(2.5f);
  ASSERT_TRUE(app_->calibrated());
  send_arm();
  const int iterations = run_for(0.5f) + 255;  // 2.5 s + 0.05 s before, at 100 Hz
  ASSERT_EQ(app_->mode(), quad::fw::FlightMode::kManual);

  int idle = 0, flown = 0, complete = 0;
  const std::vector<TracePoint>& t = board_.trace;
  for (size_t i = 0; i < t.size();) {
    ASSERT_EQ(t[i], TracePoint::kStepBegin) << "mark " << i;
    ASSERT_LT(i + 5, t.size());
    ASSERT_EQ(t[i + 1], TracePoint::kEstimated) << "mark " << i + 1;
    ASSERT_EQ(t[i + 2], TracePoint::kModesDone) << "mark " << i + 2;
    ASSERT_TRUE(t[i + 3] == TracePoint::kControlIdle || t[i + 3] == TracePoint::kControlFlown) << "mark " << i + 3;
    (t[i + 3] == TracePoint::kControlFlown ? flown : idle) += 1;
    ASSERT_EQ(t[i + 4], TracePoint::kTelemetryDone) << "mark " << i + 4;
    ASSERT_EQ(t[i + 5], TracePoint::kStepEnd) << "mark " << i + 5;
    ++complete;
    i += 6;
  }
  EXPECT_EQ(complete, iterations);
  EXPECT_NEAR(flown, 50, 1) << "armed in MANUAL for the last 0.5 s";
  EXPECT_EQ(idle + flown, complete);
}

TEST_F(BoardRunner, NoIterationWithoutANewImuSample) {
  board_.imu_new = false;
  EXPECT_EQ(run_for(0.5f), 0);
  EXPECT_TRUE(board_.motor_writes.empty());
}

TEST_F(BoardRunner, RcChannelsArmAndDriveTheMotors) {
  run_for(2.5f);  // calibration
  ASSERT_TRUE(app_->calibrated());
  mav::CommandLong arm;
  arm.command = mav::kCmdComponentArmDisarm;
  arm.param1 = 1.0f;
  arm.target_system = 1;

  rc(1600);  // throttle channel (index 2) up: arming refused
  run_for(0.05f);
  receive(quad::hal::kUart2, arm);
  run_for(0.05f);
  ASSERT_EQ(acks(quad::hal::kUart2).size(), 1u);
  EXPECT_EQ(acks(quad::hal::kUart2).back().result, mav::kResultDenied);

  rc(1000);  // throttle down: accepted
  run_for(0.05f);
  receive(quad::hal::kUart2, arm);
  run_for(0.05f);
  ASSERT_EQ(acks(quad::hal::kUart2).size(), 2u);
  EXPECT_EQ(acks(quad::hal::kUart2).back().result, mav::kResultAccepted);
  EXPECT_EQ(app_->mode(), quad::fw::FlightMode::kManual);
  for (float u : board_.motor_writes.back()) EXPECT_EQ(u, 0.0f) << "throttle down: motors off";

  rc(1500);  // half throttle on a level, still vehicle: four equal commands sqrt(1/2)
  run_for(0.05f);
  for (float u : board_.motor_writes.back()) EXPECT_NEAR(u, 0.7071f, 0.06f);
  EXPECT_TRUE(board_.tx[quad::hal::kUart0].size() > 0 && board_.tx[quad::hal::kUart2].size() > 0)
      << "telemetry on both ports";
}

}  // namespace
