// quad_gs against quad_firmware over pseudo-terminals: the test plays the simulator on UART0 (lockstep
// HIL_SENSOR for a still vehicle) and carries the radio (UART2) to a third pseudo-terminal where the
// ground-station tool runs, as a user driving a HIL flight by hand would.
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "child_port_pty.h"
#include "param_file.h"
#include "quad/firmware/params.h"
#include "quad/link/mavlink.h"
#include "command_output.h"

namespace {

namespace mav = quad::mavlink;

using Pty = quad_test::ChildPortPty;

// The simulator and the radio in one thread: a HIL step every 5 ms (lockstep: wait for the answer),
// and every byte copied between the firmware's UART2 and the ground station's terminal.
class World {
 public:
  // usb_ground (optional): a terminal for a tool on the USB cable, sharing UART0 with the simulator; the
  // firmware's frames other than the HIL answers are copied to it.
  World(int uart0, int radio_vehicle, int radio_ground, int usb_ground = -1)
      : uart0_(uart0), radio_vehicle_(radio_vehicle), radio_ground_(radio_ground), usb_ground_(usb_ground),
        thread_([this] { run(); }) {}
  ~World() {
    stop_ = true;
    thread_.join();
  }
  int steps() const { return steps_; }
  // Set when a tool is on the USB terminal (else the terminal would queue older status lines).
  std::atomic<bool> forward_usb{false};
  // Set: a vision fix of the vehicle at the origin with every HIL step (VISION_POSITION_ESTIMATE from
  // the vision station's ids, captured at the step's time), on UART0 after the step's answer so that its
  // bytes never interleave with the tool's on the radio.
  std::atomic<bool> vision{false};
  // Radio faults on the vehicle-to-ground path, as whole frames: every n-th LOG_DATA lost (0: none), and
  // a link that carries nothing at all while `radio_down` is set.
  std::atomic<int> drop_every_log_data{0};
  std::atomic<bool> radio_down{false};
  std::atomic<int> log_data_dropped{0};
  // The motor commands of the latest HIL_ACTUATOR_CONTROLS.
  std::array<float, 4> motors() {
    std::lock_guard<std::mutex> lock(motors_mutex_);
    return motors_;
  }

 private:
  void run() {
    mav::Sender sim(1, 200);
    mav::Sender vision_station(1, 197);
    mav::Parser parser;
    mav::Parser downlink_parser;
    uint64_t t_us = 1000000;
    while (!stop_) {
      mav::HilSensor s;
      s.time_usec = t_us;
      s.zacc = -9.80665f;
      s.xmag = 0.21f;
      s.zmag = 0.43f;
      s.fields_updated = 0x1FF;
      uint8_t buf[mav::max_frame_length<mav::HilSensor>()];
      const size_t n = sim.encode(s, buf, sizeof buf);
      if (write(uart0_, buf, n) != static_cast<ssize_t>(n)) break;
      bool answered = false;
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(200);
      while (!answered && !stop_ && std::chrono::steady_clock::now() < deadline) {
        pollfd p{uart0_, POLLIN, 0};
        poll(&p, 1, 5);
        uint8_t in[512];
        ssize_t got;
        while ((got = read(uart0_, in, sizeof in)) > 0) {
          parser.feed(in, static_cast<size_t>(got), [&](const mav::Frame& f) {
            if (f.message_id == mav::HilActuatorControls::kId) {
              answered = true;
              mav::HilActuatorControls act;
              if (mav::decode(f, act)) {
                std::lock_guard<std::mutex> lock(motors_mutex_);
                for (int i = 0; i < 4; ++i) motors_[i] = act.controls[i];
              }
            } else if (usb_ground_ >= 0 && forward_usb && write(usb_ground_, f.bytes, f.size) < 0) {
              // nobody on the USB terminal: nothing to deliver
            }
          });
        }
      }
      if (vision && answered) {
        mav::VisionPositionEstimate fix;
        fix.usec = t_us;
        uint8_t vbuf[mav::max_frame_length<mav::VisionPositionEstimate>()];
        const size_t vn = vision_station.encode(fix, vbuf, sizeof vbuf);
        if (write(uart0_, vbuf, vn) != static_cast<ssize_t>(vn)) break;
      }
      t_us += 10000;
      ++steps_;
      downlink(&downlink_parser);
      copy(radio_ground_, radio_vehicle_);
      if (usb_ground_ >= 0) copy(usb_ground_, uart0_);
      std::this_thread::sleep_for(std::chrono::milliseconds(3));
    }
  }
  // The vehicle's radio frames to the ground, less the ones the faults take.
  void downlink(mav::Parser* parser) {
    uint8_t buf[1024];
    ssize_t n;
    while ((n = read(radio_vehicle_, buf, sizeof buf)) > 0) {
      parser->feed(buf, static_cast<size_t>(n), [&](const mav::Frame& f) {
        if (radio_down) return;
        const int every = drop_every_log_data;
        if (f.message_id == mav::LogData::kId && every > 0 && ++log_data_seen_ % every == 0) {
          ++log_data_dropped;
          return;
        }
        if (write(radio_ground_, f.bytes, f.size) < 0) return;  // nobody on the terminal: nothing to deliver
      });
    }
  }
  // Whatever is readable; errors (the tool not running: EIO) just mean nothing to copy.
  static void copy(int from, int to) {
    uint8_t buf[1024];
    ssize_t n;
    while ((n = read(from, buf, sizeof buf)) > 0) {
      if (write(to, buf, static_cast<size_t>(n)) < 0) break;
    }
  }

  int uart0_, radio_vehicle_, radio_ground_, usb_ground_;
  std::mutex motors_mutex_;
  std::array<float, 4> motors_{{0.0f, 0.0f, 0.0f, 0.0f}};
  std::atomic<bool> stop_{false};
  std::atomic<int> steps_{0};
  int log_data_seen_ = 0;
  std::thread thread_;
};

using Result = quad::test::CommandOutput;

Result gs(const std::string& port, const std::string& args) {
  return quad::test::run_command(std::string(QUAD_GS_EXE) + " --port " + port + " --baud 57600 " + args);
}

// Starts the host firmware on the two pseudo-terminals with a short calibration and no RC requirement
// (these sessions have no sticks), and with `storage` as its parameter store when given.
// log_dir: the firmware's flight logs (--log-dir) when given.
pid_t start_firmware(const Pty& uart0, const Pty& uart2, const std::string& name, const std::string& storage = "",
                     const std::string& log_dir = "") {
  const std::string params = ::testing::TempDir() + name + ".params";
  // With logs: the IMU every 10th iteration, so that a session's log downloads in seconds.
  std::ofstream(params) << "CAL_TIME 1.0\nFS_RC_ENABLE 0\n" << (log_dir.empty() ? "" : "LOG_IMU_DIV 10\n");
  std::vector<std::string> args = {QUAD_FIRMWARE_EXE, "--uart0", uart0.path, "--uart2", uart2.path, "--params", params};
  if (!storage.empty()) args.insert(args.end(), {"--storage", storage});
  if (!log_dir.empty()) args.insert(args.end(), {"--log-dir", log_dir});
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(&a[0]);
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    execv(QUAD_FIRMWARE_EXE, argv.data());
    _exit(127);
  }
  return pid;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Hangs up UART0, which ends the firmware; true if it ended by itself within 3 s (else it is killed).
bool stop_firmware(Pty& uart0, pid_t pid) {
  close(uart0.master);
  uart0.master = -1;
  int status = 0;
  for (int i = 0; i < 300 && waitpid(pid, &status, WNOHANG) == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  if (waitpid(pid, &status, WNOHANG) != 0) return true;
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return false;
}

// node-mavlink reads a record quad_gs wrote (tools/node/tlog_check.js): every record one frame with a
// valid CRC, time stamps in order, and the required frames. Returns its output; status in *status.
std::string check_tlog(const std::string& path, const std::string& requirements, int* status) {
  const std::string cmd = std::string("'") + QUAD_NODE_EXECUTABLE + "' '" + QUAD_NODE_DIR + "/tlog_check.js' '" + path +
                          "' " + requirements;
  const quad::test::CommandOutput r = quad::test::run_command(cmd);
  *status = r.status;
  return cmd + "\n" + r.out;
}

TEST(GroundStation, DrivesTheFirmwareOverTheRadio) {
  Pty uart0, uart2, ground;
  ASSERT_FALSE(ground.path.empty());
  const pid_t pid = start_firmware(uart0, uart2, "gs_test");
  ASSERT_GT(pid, 0);
  {
    World world(uart0.master, uart2.master, ground.master);
    // Calibrated (1 s) and the ground hold on (0.5 s still): the pre-arm check passes.
    while (world.steps() < 180) std::this_thread::sleep_for(std::chrono::milliseconds(10));

    Result r = gs(ground.path, "arm");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("accepted"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("vehicle: MANUAL: armed"), std::string::npos) << r.out;

    r = gs(ground.path, "watch 3");  // at least 100 lockstep iterations even on a busy machine
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("mode MANUAL (armed)"), std::string::npos) << "from the 1 Hz heartbeat: " << r.out;
    EXPECT_NE(r.out.find("p ("), std::string::npos) << "the position estimate: " << r.out;

    r = gs(ground.path, "mode auto");
    EXPECT_EQ(r.status, 1) << "no vision fix yet: " << r.out;
    EXPECT_NE(r.out.find("auto refused: no vision fix"), std::string::npos) << r.out;

    r = gs(ground.path, "setpoint 0.5 -0.2 -1.5 90");
    EXPECT_EQ(r.status, 0) << r.out;

    r = gs(ground.path, "set POS_KP_Z 2.5");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("POS_KP_Z         2.5"), std::string::npos) << r.out;
    r = gs(ground.path, "get POS_KP_Z");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("2.5"), std::string::npos) << r.out;
    r = gs(ground.path, "set POS_KP_Z 1000");
    EXPECT_EQ(r.status, 1) << "out of range: " << r.out;
    EXPECT_NE(r.out.find("param out of range: POS_KP_Z"), std::string::npos) << r.out;

    // The list is every parameter, in the format quad_firmware --params reads back.
    r = gs(ground.path, "params");
    ASSERT_EQ(r.status, 0) << r.out;
    std::string listing;
    int lines = 0;
    std::istringstream in(r.out);
    for (std::string line; std::getline(in, line);) {
      if (line.rfind("vehicle:", 0) == 0) continue;  // status text on stderr
      listing += line + "\n";
      ++lines;
    }
    EXPECT_EQ(lines, quad::fw::kParamCount);
    std::vector<quad::fw::ParamOverride> parsed;
    std::string error;
    ASSERT_TRUE(quad::fw::parse_param_text(listing, "listing", &parsed, &error)) << error;
    ASSERT_EQ(parsed.size(), static_cast<size_t>(quad::fw::kParamCount));
    for (const auto& p : parsed) {
      if (p.index == quad::fw::kPosKpZ) EXPECT_FLOAT_EQ(p.value, 2.5f);
      if (p.index == quad::fw::kCalTime) EXPECT_FLOAT_EQ(p.value, 1.0f);
    }

    r = gs(ground.path, "disarm");
    EXPECT_EQ(r.status, 0) << "on the ground: " << r.out;
    EXPECT_NE(r.out.find("DISARMED: disarmed"), std::string::npos) << r.out;

    r = gs(ground.path, "get NO_SUCH_PARAM");
    EXPECT_EQ(r.status, 1) << r.out;
  }
  EXPECT_TRUE(stop_firmware(uart0, pid)) << "the firmware did not end when UART0 hung up";
}

// The motor commands as shares of the mean rotor thrust f_i = f_max u_i^2 (VEH_FRAME 0, the plus layout:
// motor 0 front, 1 left, 2 back, 3 right): pitch (nose up) ~ f_front - f_back, roll ~ f_left - f_right.
struct MotorShares {
  float mean = 0.0f, pitch = 0.0f, roll = 0.0f;
};
MotorShares shares(const std::array<float, 4>& u) {
  MotorShares s;
  float f[4];
  for (int i = 0; i < 4; ++i) s.mean += (f[i] = u[i] * u[i]) / 4.0f;
  if (s.mean > 0.0f) {
    s.pitch = (f[0] - f[2]) / s.mean;
    s.roll = (f[1] - f[3]) / s.mean;
  }
  return s;
}

void wait_steps(const World& world, int n) {
  const int until = world.steps() + n;
  while (world.steps() < until) std::this_thread::sleep_for(std::chrono::milliseconds(5));
}

// AUTO with a vision fix, a position setpoint that the position controller then flies towards (seen in
// the motor commands: the target changed), and the land command.
TEST(GroundStation, AutoSetpointAndLand) {
  Pty uart0, uart2, ground;
  ASSERT_FALSE(ground.path.empty());
  const pid_t pid = start_firmware(uart0, uart2, "gs_auto_test");
  ASSERT_GT(pid, 0);
  {
    World world(uart0.master, uart2.master, ground.master);
    // Calibrated (1 s) and the ground hold on (0.5 s still): the pre-arm check passes.
    while (world.steps() < 180) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    world.vision = true;  // the vision station sees the vehicle at the origin from now on
    wait_steps(world, 20);

    Result r = gs(ground.path, "arm");
    ASSERT_EQ(r.status, 0) << r.out;
    r = gs(ground.path, "mode auto");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("accepted"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("vehicle: AUTO: auto selected"), std::string::npos) << r.out;

    // Holding where it is (the origin; the simulated vehicle is still): hover thrust, 1.4 kg on four
    // 880 g motors = 0.398 of f_max each, and no tilt.
    wait_steps(world, 50);
    const MotorShares hold = shares(world.motors());
    EXPECT_NEAR(hold.mean, 1.4f / (4.0f * 0.88f), 0.02f);
    EXPECT_LT(std::fabs(hold.pitch), 0.01f);
    EXPECT_LT(std::fabs(hold.roll), 0.01f);

    // 1 m north and 1.5 m up: the controller climbs (more thrust) and pitches nose down (the back motor
    // pulls harder), since the vehicle in this simulation does not move.
    r = gs(ground.path, "setpoint 1.0 0 -1.5");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("setpoint sent: N 1.000 E 0.000 D -1.500"), std::string::npos) << r.out;
    wait_steps(world, 100);
    const MotorShares moved = shares(world.motors());
    EXPECT_GT(moved.mean, 1.1f * hold.mean) << "climbing";
    EXPECT_LT(moved.pitch, -0.05f) << "towards north";
    EXPECT_LT(std::fabs(moved.roll), 0.01f) << "nothing east";
    std::printf("motor thrust share: hold %.3f (pitch %.4f), after the setpoint %.3f (pitch %.4f)\n", hold.mean,
                hold.pitch, moved.mean, moved.pitch);

    r = gs(ground.path, "land");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("accepted"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("vehicle: LANDING: land commanded"), std::string::npos) << r.out;
    // Still on the ground: the land detector ends the landing after LAND_TIME (1 s).
    r = gs(ground.path, "watch 4");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("mode DISARMED"), std::string::npos) << r.out;
  }
  stop_firmware(uart0, pid);
}

// The signed radio: the key goes in over the USB cable (quad_gs signing-setup), SIGN_ENABLE is set, and
// from then on only a quad_gs holding the key commands the vehicle over the radio.
TEST(GroundStation, SignedRadioSession) {
  Pty uart0, uart2, ground, usb;
  ASSERT_FALSE(usb.path.empty());
  const std::string storage = ::testing::TempDir() + "gs_sign_test.storage";
  std::remove(storage.c_str());
  const pid_t pid = start_firmware(uart0, uart2, "gs_sign_test", storage);
  ASSERT_GT(pid, 0);
  {
    World world(uart0.master, uart2.master, ground.master, usb.master);
    // Calibrated (1 s) and the ground hold on (0.5 s still): the pre-arm check passes.
    while (world.steps() < 180) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const std::string key = "--key 'correct horse battery staple' ";

    Result r = gs(ground.path, key + "signing-setup");
    EXPECT_EQ(r.status, 1) << "refused on the radio: " << r.out;
    EXPECT_NE(r.out.find("signing: key refused on radio"), std::string::npos) << r.out;

    world.forward_usb = true;
    r = gs(usb.path, key + "signing-setup");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("vehicle: signing: key set"), std::string::npos) << r.out;
    r = gs(usb.path, "set SIGN_ENABLE 1");
    EXPECT_EQ(r.status, 0) << r.out;

    r = gs(ground.path, "arm");
    EXPECT_EQ(r.status, 1) << "unsigned: no answer " << r.out;
    r = gs(ground.path, "--key 'wrong horse' arm");
    EXPECT_EQ(r.status, 1) << "wrong key: no answer " << r.out;
    EXPECT_NE(r.out.find("frames with a wrong signature dropped"), std::string::npos) << "the vehicle's telemetry fails our check too: " << r.out;

    const std::string tlog = ::testing::TempDir() + "gs_sign_test.tlog";
    r = gs(ground.path, key + "--tlog " + tlog + " arm");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("vehicle: MANUAL: armed"), std::string::npos) << r.out;
    // The record holds the signed frames both ways, each whole (13-byte signature block included).
    int status = -1;
    const std::string check = check_tlog(tlog, "--require COMMAND_LONG@255 --require COMMAND_ACK@1", &status);
    EXPECT_EQ(status, 0) << check;
    r = gs(ground.path, key + "disarm");
    EXPECT_EQ(r.status, 0) << r.out;
    r = gs(ground.path, key + "get SIGN_ENABLE");
    EXPECT_EQ(r.status, 0) << r.out;
  }
  stop_firmware(uart0, pid);
  std::remove(storage.c_str());
}

// --tlog: the parameter list's session as a record, read back by node-mavlink's own tlog reader.
TEST(GroundStation, RecordsTheSessionAsATlog) {
  Pty uart0, uart2, ground;
  ASSERT_FALSE(ground.path.empty());
  const pid_t pid = start_firmware(uart0, uart2, "gs_tlog_test");
  ASSERT_GT(pid, 0);
  const std::string tlog = ::testing::TempDir() + "gs_tlog_test.tlog";
  {
    World world(uart0.master, uart2.master, ground.master);
    // Calibrated (1 s) and the ground hold on (0.5 s still): the pre-arm check passes.
    while (world.steps() < 180) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    const Result r = gs(ground.path, "--tlog " + tlog + " params");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("frames recorded in " + tlog), std::string::npos) << r.out;
  }
  stop_firmware(uart0, pid);
  int status = -1;
  const std::string check = check_tlog(tlog, "--require PARAM_REQUEST_LIST@255 --require PARAM_VALUE@1:" +
                                                 std::to_string(quad::fw::kParamCount), &status);
  EXPECT_EQ(status, 0) << check;
  EXPECT_NE(check.find("255 190 PARAM_REQUEST_LIST"), std::string::npos) << check;

  const Result bad = gs("/dev/null", "--tlog /nonexistent/dir/x.tlog arm");
  EXPECT_EQ(bad.status, 2) << bad.out;
  EXPECT_NE(bad.out.find("/nonexistent/dir/x.tlog: cannot create"), std::string::npos) << bad.out;
}

// The flight log of a short armed session, downloaded over the radio with the MAVLink log protocol: lost
// LOG_DATA frames re-requested, a download cut by a dead link resumed by running the command again, the
// file byte for byte the one the firmware wrote and read by @foxglove/ulog; then the logs erased.
TEST(GroundStation, DownloadsResumesAndErasesTheFlightLogs) {
  Pty uart0, uart2, ground;
  ASSERT_FALSE(ground.path.empty());
  const std::string dir = ::testing::TempDir() + "gs_logs";
  std::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "'").c_str());
  const pid_t pid = start_firmware(uart0, uart2, "gs_logs_test", "", dir);
  ASSERT_GT(pid, 0);
  const std::string written = dir + "/log_001.ulg", got = ::testing::TempDir() + "gs_logs_download.ulg";
  std::remove(got.c_str());
  {
    World world(uart0.master, uart2.master, ground.master);
    // Calibrated (1 s) and the ground hold on (0.5 s still): the pre-arm check passes.
    while (world.steps() < 180) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    Result r = gs(ground.path, "logs list");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("no logs"), std::string::npos) << r.out;
    ASSERT_EQ(gs(ground.path, "arm").status, 0);
    wait_steps(world, 150);
    ASSERT_EQ(gs(ground.path, "disarm").status, 0);
    const std::string log = read_file(written);
    ASSERT_GT(log.size(), 8000u) << "the armed session's log";

    r = gs(ground.path, "logs list");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find(std::to_string(log.size())), std::string::npos) << "log 1's size: " << r.out;

    // A link that dies after a few frames: quad_gs gives up, keeps what it has, and resumes.
    std::thread cut([&] {
      while (world.log_data_dropped < 3) std::this_thread::sleep_for(std::chrono::milliseconds(5));
      std::this_thread::sleep_for(std::chrono::milliseconds(300));
      world.radio_down = true;
    });
    world.drop_every_log_data = 7;
    r = gs(ground.path, "logs download 1 " + got);
    cut.join();
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_NE(r.out.find("run the same command again to resume"), std::string::npos) << r.out;
    world.radio_down = false;
    r = gs(ground.path, "logs download 1 " + got);
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("resuming log 1 at"), std::string::npos) << r.out;
    EXPECT_GT(world.log_data_dropped, 3) << "frames were lost and re-requested";
    EXPECT_TRUE(read_file(got) == log) << "the download differs from the log the firmware wrote";

    r = gs(ground.path, "logs erase");
    EXPECT_EQ(r.status, 0) << r.out;
    r = gs(ground.path, "logs list");
    EXPECT_NE(r.out.find("no logs"), std::string::npos) << r.out;
  }
  stop_firmware(uart0, pid);
  int status = -1;
  const std::string cmd = std::string("'") + QUAD_NODE_EXECUTABLE + "' '" + QUAD_NODE_DIR + "/ulog_check.js' '" + got + "' 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  char buf[256];
  while (fgets(buf, sizeof buf, p) != nullptr) out += buf;
  status = pclose(p);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << cmd << "\n" << out;
  EXPECT_NE(out.find("sensor_combined"), std::string::npos) << out;
}

TEST(GroundStation, UsageErrors) {
  Result r = gs("/nonexistent/tty", "arm");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("/nonexistent/tty"), std::string::npos) << r.out;
  r = gs("/dev/null", "fly");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("unknown command 'fly'"), std::string::npos) << r.out;
  r = gs("/dev/null", "arm --baud 57600x");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("--baud: '57600x' is not a supported baud rate"), std::string::npos) << r.out;
  r = gs("/dev/null", "setpoint 1 x 2");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("not a number: 'x'"), std::string::npos) << r.out;
}

}  // namespace
