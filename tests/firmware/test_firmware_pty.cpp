// quad_firmware over real pseudo-terminal pairs: this test plays the simulator (and a ground station)
// exactly as docs/hil-protocol.md describes. It starts the executable on the slave ends, sends
// HIL_SENSOR for a still vehicle at 100 Hz, arms over MAVLink and checks that every sensor message is
// answered by one HIL_ACTUATOR_CONTROLS with the same time stamp, the lockstep flag and the armed flag,
// and that the motors answer the throttle stick. Also: the command line's errors.
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "child_port_pty.h"
#include "quad/link/mavlink.h"
#include "command_output.h"

namespace {

namespace mav = quad::mavlink;
using Clock = std::chrono::steady_clock;

using Pty = quad_test::ChildPortPty;

// The peer side of one port: encodes as one sender, parses everything coming back.
class Peer {
 public:
  Peer(int fd, uint8_t sysid, uint8_t compid) : fd_(fd), sender_(sysid, compid) {}

  template <class Msg>
  void send(const Msg& msg) {
    uint8_t buf[mav::max_frame_length<Msg>()];
    const size_t n = sender_.encode(msg, buf, sizeof buf);
    ASSERT_EQ(write(fd_, buf, n), static_cast<ssize_t>(n));
  }

  // Reads what is available (waiting up to timeout_ms for the first byte) and collects the frames.
  void pump(int timeout_ms) {
    pollfd p{fd_, POLLIN, 0};
    if (poll(&p, 1, timeout_ms) <= 0) return;
    uint8_t buf[1024];
    ssize_t n;
    while ((n = read(fd_, buf, sizeof buf)) > 0) {
      parser_.feed(buf, static_cast<size_t>(n), [this](const mav::Frame& f) { on_frame(f); });
    }
  }

  // Waits until pred() holds or the deadline passes.
  template <class Pred>
  bool wait_for(Pred pred, int timeout_ms) {
    const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
    while (!pred()) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return false;
      pump(static_cast<int>(std::min<long long>(left, 50)));
    }
    return true;
  }

  std::vector<mav::HilActuatorControls> actuators;
  std::vector<Clock::time_point> actuator_arrival;
  std::vector<mav::CommandAck> acks;
  std::vector<std::string> texts;
  std::vector<mav::Heartbeat> heartbeats;
  int attitude = 0;
  int position = 0;
  int sys_status = 0;
  mav::SysStatus last_status;

 private:
  void on_frame(const mav::Frame& f) {
    EXPECT_EQ(f.system_id, 1);
    EXPECT_EQ(f.component_id, 1);
    mav::HilActuatorControls a;
    mav::CommandAck ack;
    mav::Statustext text;
    mav::Heartbeat hb;
    if (mav::decode(f, a)) {
      actuators.push_back(a);
      actuator_arrival.push_back(Clock::now());
    } else if (mav::decode(f, ack)) {
      acks.push_back(ack);
    } else if (mav::decode(f, text)) {
      texts.emplace_back(text.text, strnlen(text.text, sizeof text.text));
    } else if (mav::decode(f, hb)) {
      heartbeats.push_back(hb);
    } else if (mav::decode(f, last_status)) {
      ++sys_status;
    } else if (f.message_id == mav::AttitudeQuaternion::kId) {
      ++attitude;
    } else if (f.message_id == mav::LocalPositionNed::kId) {
      ++position;
    }
  }

  int fd_;
  mav::Sender sender_;
  mav::Parser parser_;
};

bool contains(const std::vector<std::string>& texts, const std::string& needle) {
  return std::any_of(texts.begin(), texts.end(), [&](const std::string& t) { return t.find(needle) != std::string::npos; });
}

pid_t start_firmware(const std::vector<std::string>& args) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    static std::string exe = QUAD_FIRMWARE_EXE;
    argv.push_back(&exe[0]);
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

// Waits for the child; kills it after timeout_ms. Returns its exit status, or -1 if it had to be killed.
int reap(pid_t pid, int timeout_ms) {
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
  int status = 0;
  while (Clock::now() < deadline) {
    if (waitpid(pid, &status, WNOHANG) == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return -1;
}

// Kills the firmware if a failed assertion leaves the test early.
struct ChildGuard {
  pid_t pid;
  ~ChildGuard() {
    if (pid > 0 && waitpid(pid, nullptr, WNOHANG) == 0) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
  }
};

std::string temp_file(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

mav::HilSensor still_sample(uint64_t t_us, int k) {
  mav::HilSensor s;
  s.time_usec = t_us;
  // A level, still vehicle with a small gyro bias and a little deterministic noise.
  const float wobble = 0.002f * static_cast<float>((k * 7919) % 11 - 5);
  s.xacc = wobble;
  s.yacc = -wobble;
  s.zacc = -9.80665f + wobble;
  s.xgyro = 0.01f + 0.1f * wobble;
  s.ygyro = -0.005f;
  s.zgyro = 0.002f;
  s.xmag = 0.21f;
  s.ymag = 0.0f;
  s.zmag = 0.43f;
  s.fields_updated = 0x1FF;
  return s;
}

mav::ManualControl sticks(int16_t throttle) {
  mav::ManualControl m;
  m.target = 1;
  m.z = throttle;
  return m;
}

TEST(FirmwarePty, AnswersEverySensorMessageAndArms) {
  Pty uart0, uart2;
  ASSERT_FALSE(uart0.path.empty());
  ASSERT_FALSE(uart2.path.empty());
  const std::string params = temp_file("fw_pty.params", "# short calibration for the test (at least 100 samples)\nCAL_TIME 1.0\n");
  const pid_t pid = start_firmware({"--uart0", uart0.path, "--uart0-baud", "921600", "--uart2", uart2.path,
                                    "--uart2-baud", "57600", "--params", params});
  ASSERT_GT(pid, 0);
  ChildGuard guard{pid};

  Peer sim(uart0.master, 1, 200);       // the simulator poses as the vehicle's sensors
  Peer ground(uart0.master, 255, 190);  // a ground station on the same USB port (sends only)
  Peer radio(uart2.master, 1, 197);     // the vision station's end of the radio

  // The firmware announces itself (STATUSTEXT) once its ports are open.
  ASSERT_TRUE(sim.wait_for([&] { return contains(sim.texts, "calibrating"); }, 5000));
  ASSERT_TRUE(radio.wait_for([&] { return contains(radio.texts, "calibrating"); }, 1000));

  constexpr int kSteps = 210;  // the 1 Hz heartbeat at iteration 200 reports the armed mode
  constexpr int kArmAt = 160;       // 1.6 s: after the 1 s calibration and the ground hold's 0.5 s (pre-arm)
  constexpr int kThrottleAt = 180;  // half throttle from here
  const auto start = Clock::now();
  std::vector<double> latency_ms;
  for (int k = 0; k < kSteps; ++k) {
    std::this_thread::sleep_until(start + std::chrono::milliseconds(10 * k));  // 100 Hz
    const uint64_t t_us = 1000000ull + 10000ull * static_cast<uint64_t>(k);
    if (k % 5 == 0) ground.send(sticks(k >= kThrottleAt ? 500 : 0));
    if (k == kArmAt) {
      mav::CommandLong arm;
      arm.command = mav::kCmdComponentArmDisarm;
      arm.param1 = 1.0f;
      arm.target_system = 1;
      arm.target_component = 1;
      ground.send(arm);
    }
    const auto sent = Clock::now();
    sim.send(still_sample(t_us, k));
    const size_t expect = static_cast<size_t>(k + 1);
    ASSERT_TRUE(sim.wait_for([&] { return sim.actuators.size() >= expect; }, 2000)) << "no answer to step " << k;
    latency_ms.push_back(std::chrono::duration<double, std::milli>(sim.actuator_arrival.back() - sent).count());
    radio.pump(0);
  }
  // Let the telemetry of the last iterations arrive.
  sim.pump(50);
  radio.pump(50);

  // One answer per sensor message, in order, stamped with its time, lockstep flag set.
  ASSERT_EQ(sim.actuators.size(), static_cast<size_t>(kSteps));
  for (int k = 0; k < kSteps; ++k) {
    const mav::HilActuatorControls& a = sim.actuators[k];
    EXPECT_EQ(a.time_usec, 1000000ull + 10000ull * static_cast<uint64_t>(k));
    EXPECT_EQ(a.flags, mav::kHilActuatorControlsFlagLockstep);
    const bool armed = (a.mode & mav::kModeFlagSafetyArmed) != 0;
    EXPECT_EQ(armed, k >= kArmAt) << "step " << k;
    EXPECT_NE(a.mode & mav::kModeFlagHilEnabled, 0);
    for (int i = 4; i < 16; ++i) EXPECT_EQ(a.controls[i], 0.0f);
    if (!armed) {
      for (int i = 0; i < 4; ++i) EXPECT_EQ(a.controls[i], 0.0f) << "disarmed motors must be off";
    }
  }
  // The answer comes back within one control period (median over the run, robust to a busy machine).
  std::sort(latency_ms.begin(), latency_ms.end());
  EXPECT_LT(latency_ms[latency_ms.size() / 2], 10.0);

  // Arming was acknowledged and reported.
  ASSERT_FALSE(sim.acks.empty());
  EXPECT_EQ(sim.acks.back().command, mav::kCmdComponentArmDisarm);
  EXPECT_EQ(sim.acks.back().result, mav::kResultAccepted);
  EXPECT_TRUE(contains(sim.texts, "calibrated")) << "texts: " << sim.texts.size();
  EXPECT_TRUE(contains(sim.texts, "MANUAL: armed"));
  EXPECT_TRUE(contains(radio.texts, "MANUAL: armed")) << "STATUSTEXT goes out on the radio too";

  // Half throttle on a level vehicle: four equal commands. Thrust = 0.5 * 4 * f_max, so each motor
  // gives f_max / 2 and its command u = sqrt(1/2) (f = f_max u^2, control/vehicle.h).
  const mav::HilActuatorControls& last = sim.actuators.back();
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(last.controls[i], 0.7071f, 0.06f) << "motor " << i;
    EXPECT_NEAR(last.controls[i], last.controls[0], 0.03f) << "a level, still vehicle needs no torque";
  }

  // Telemetry on both ports: heartbeat at 1 Hz, attitude and position at 10 Hz, SYS_STATUS at 1 Hz.
  ASSERT_GE(sim.heartbeats.size(), 1u);
  EXPECT_GE(radio.heartbeats.size(), 1u);
  EXPECT_EQ(sim.heartbeats.back().custom_mode, 1u) << "MANUAL";
  EXPECT_EQ(sim.heartbeats.back().type, mav::kMavTypeQuadrotor);
  EXPECT_NEAR(sim.attitude, kSteps / 10, 2);
  EXPECT_NEAR(sim.position, kSteps / 10, 2);
  EXPECT_GE(sim.sys_status, 1);
  EXPECT_LE(sim.last_status.load, 1000);

  // The simulator hangs up: the firmware ends by itself, successfully.
  close(uart0.master);
  uart0.master = -1;
  close(uart0.slave);
  uart0.slave = -1;
  EXPECT_EQ(reap(pid, 3000), 0);
  guard.pid = -1;
}

std::string run_capture(const std::string& args, int* status) {
  const quad::test::CommandOutput r = quad::test::run_command(std::string(QUAD_FIRMWARE_EXE) + " " + args);
  *status = r.status;
  return r.out;
}

TEST(FirmwareCli, PortThatCannotBeOpenedIsAClearError) {
  int status = 0;
  const std::string out = run_capture("--uart0 /nonexistent/ttyQ9", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("uart0"), std::string::npos) << out;
  EXPECT_NE(out.find("/nonexistent/ttyQ9"), std::string::npos) << out;
  EXPECT_NE(out.find("No such file"), std::string::npos) << out;
}

TEST(FirmwareCli, Uart2ThatCannotBeOpenedIsAClearError) {
  Pty uart0;
  int status = 0;
  const std::string out = run_capture("--uart0 " + uart0.path + " --uart2 /nonexistent/radio", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("uart2"), std::string::npos) << out;
  EXPECT_NE(out.find("/nonexistent/radio"), std::string::npos) << out;
}

TEST(FirmwareCli, BadParameterFileNamesFileLineAndField) {
  Pty uart0;
  int status = 0;
  const std::string unknown = temp_file("fw_unknown.params", "SYS_LOOP_HZ 100\n\nNOT_A_PARAM 3\n");
  std::string out = run_capture("--uart0 " + uart0.path + " --params " + unknown, &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find(unknown + ":3: unknown parameter 'NOT_A_PARAM'"), std::string::npos) << out;

  const std::string range = temp_file("fw_range.params", "SYS_LOOP_HZ 5000\n");
  out = run_capture("--uart0 " + uart0.path + " --params " + range, &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find(range + ":1: SYS_LOOP_HZ: 5000 is outside [50, 1000]"), std::string::npos) << out;

  const std::string number = temp_file("fw_number.params", "# gains\nATT_ALPHA 3.0x\n");
  out = run_capture("--uart0 " + uart0.path + " --params " + number, &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find(number + ":2: ATT_ALPHA: value '3.0x' is not a finite number"), std::string::npos) << out;

  out = run_capture("--uart0 " + uart0.path + " --params /nonexistent/file.params", &status);
  EXPECT_NE(status, 0);
  EXPECT_NE(out.find("cannot open parameter file '/nonexistent/file.params'"), std::string::npos) << out;
}

TEST(FirmwareCli, BadBaudAndMissingPortAreUsageErrors) {
  int status = 0;
  std::string out = run_capture("--uart0 /dev/null --uart0-baud 12345", &status);
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("--uart0-baud: '12345' is not a supported baud rate"), std::string::npos) << out;
  out = run_capture("--params x", &status);
  EXPECT_EQ(status, 2);
  EXPECT_NE(out.find("--uart0 is required"), std::string::npos) << out;
}

}  // namespace
