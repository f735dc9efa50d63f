// A stand-in for quad_firmware that speaks docs/hil-protocol.md, so the simulator's loop can be tested
// on its own: it answers every HIL_SENSOR with HIL_ACTUATOR_CONTROLS for the same time, obeys arm /
// mode / land commands, and reports as its "estimate" the vehicle position implied by the last
// LANDING_TARGET (p_I = -p_B, valid while the vehicle is level and heading north). Armed, it commands
// 1.1 times the hover thrust on every rotor, so an armed vehicle must climb.
//
// Test options (before the port arguments the simulator appends):
//   --pad-frames K  K TIMESYNC frames (30 bytes each) before every answer: more UART0 traffic from the
//                   firmware, to load the link
//   --log-fixes     one line "fix CAPTURE_US SEEN_US" on stderr (firmware.log) per LANDING_TARGET, with
//                   its capture time stamp and the HIL time of the step at which it was read
#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <string>

#include "quad/link/mavlink.h"

namespace mav = quad::mavlink;

namespace {

int open_port(const char* path) {
  const int fd = open(path, O_RDWR | O_NOCTTY);
  if (fd < 0) {
    std::perror(path);
    std::exit(3);
  }
  termios t{};
  tcgetattr(fd, &t);
  cfmakeraw(&t);
  tcsetattr(fd, TCSANOW, &t);
  return fd;
}

template <class Msg>
void send(int fd, mav::Sender& sender, const Msg& msg) {
  uint8_t buf[mav::max_frame_length<Msg>()];
  const size_t n = sender.encode(msg, buf, sizeof buf);
  for (size_t off = 0; off < n;) {
    const ssize_t w = write(fd, buf + off, n - off);
    if (w <= 0) std::exit(0);
    off += static_cast<size_t>(w);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const char* uart0_path = nullptr;
  const char* uart2_path = nullptr;
  int pad_frames = 0;
  bool log_fixes = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--log-fixes")) log_fixes = true;
    if (i + 1 >= argc) break;
    if (!std::strcmp(argv[i], "--uart0")) uart0_path = argv[i + 1];
    if (!std::strcmp(argv[i], "--uart2")) uart2_path = argv[i + 1];
    if (!std::strcmp(argv[i], "--pad-frames")) pad_frames = std::atoi(argv[i + 1]);
  }
  if (!uart0_path || !uart2_path) {
    std::fprintf(stderr, "fake_firmware: --uart0 and --uart2 are required\n");
    return 2;
  }
  const int uart0 = open_port(uart0_path);
  const int uart2 = open_port(uart2_path);
  mav::Sender out0(1, mav::kCompIdAutopilot1), out2(1, mav::kCompIdAutopilot1);
  mav::Parser in0, in2;
  bool armed = false;
  uint32_t mode = 0;
  float est[3] = {NAN, NAN, NAN};
  uint64_t sensors = 0;
  const float hover = std::sqrt(1.1f * 1.4f * 9.80665f / 4.0f / (0.880f * 9.80665f));
  uint64_t step_usec = 0;  // the HIL time of the step being processed

  auto on_uart2 = [&](const mav::Frame& f) {
    mav::LandingTarget lt;
    if (f.message_id == mav::LandingTarget::kId && mav::decode(f, lt) && lt.frame == mav::kFrameBodyFrd) {
      est[0] = -lt.x;
      est[1] = -lt.y;
      est[2] = -lt.z;
      if (log_fixes)
        std::fprintf(stderr, "fix %llu %llu\n", static_cast<unsigned long long>(lt.time_usec),
                     static_cast<unsigned long long>(step_usec));
    }
  };
  auto on_uart0 = [&](const mav::Frame& f) {
    switch (f.message_id) {
      case mav::CommandLong::kId: {
        mav::CommandLong c;
        if (!mav::decode(f, c)) break;
        if (c.command == mav::kCmdComponentArmDisarm) armed = c.param1 > 0.5f, mode = armed ? 1 : 0;
        if (c.command == mav::kCmdDoSetMode) mode = static_cast<uint32_t>(c.param2);
        if (c.command == mav::kCmdNavLand) mode = 3;
        mav::CommandAck ack;
        ack.command = c.command;
        ack.result = mav::kResultAccepted;
        send(uart0, out0, ack);
        break;
      }
      case mav::HilSensor::kId: {
        mav::HilSensor s;
        if (!mav::decode(f, s)) break;
        // What the radio delivered before this step is in the UART2 buffer by now: take it first.
        step_usec = s.time_usec;
        uint8_t buf[1024];
        for (ssize_t n; (n = read(uart2, buf, sizeof buf)) > 0;) in2.feed(buf, static_cast<size_t>(n), on_uart2);
        if (sensors++ % 10 == 0) {
          mav::Heartbeat hb;
          hb.custom_mode = mode;
          hb.base_mode = static_cast<uint8_t>(mav::kModeFlagCustomModeEnabled | (armed ? mav::kModeFlagSafetyArmed : 0));
          send(uart0, out0, hb);
          send(uart2, out2, hb);
          mav::LocalPositionNed lp;
          lp.time_boot_ms = static_cast<uint32_t>(s.time_usec / 1000);
          lp.x = est[0];
          lp.y = est[1];
          lp.z = est[2];
          send(uart0, out0, lp);
        }
        for (int k = 0; k < pad_frames; ++k) {
          mav::Timesync ts;  // no trailing zeros: the whole 18-byte payload goes out
          ts.tc1 = 1;
          ts.ts1 = static_cast<int64_t>(s.time_usec) + 1;
          ts.target_system = 255;
          ts.target_component = 190;
          send(uart0, out0, ts);
        }
        mav::HilActuatorControls a;
        a.time_usec = s.time_usec;
        for (int i = 0; i < 4; ++i) a.controls[i] = armed ? hover : 0.0f;
        a.mode = armed ? mav::kModeFlagSafetyArmed : 0;
        a.flags = mav::kHilActuatorControlsFlagLockstep;
        send(uart0, out0, a);
        break;
      }
      default: break;
    }
  };
  fcntl(uart2, F_SETFL, fcntl(uart2, F_GETFL) | O_NONBLOCK);
  // Announce ourselves, as quad_firmware does: the simulator starts the exchange after that.
  mav::Statustext hello;
  std::strncpy(hello.text, "fake firmware ready", sizeof hello.text);
  send(uart0, out0, hello);
  uint8_t buf[4096];
  for (;;) {
    const ssize_t n = read(uart0, buf, sizeof buf);
    if (n <= 0) return 0;  // the simulator closed the port
    in0.feed(buf, static_cast<size_t>(n), on_uart0);
  }
}
