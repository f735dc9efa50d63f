// A raw pseudo-terminal pair for tests that talk to a program through a serial port path (avr_pil's
// --uart0/--uart2): the program opens `path` (the slave), the test reads and writes `master`. Both ends
// raw (no echo, no line discipline); `nonblocking_master` for tests that poll.
#pragma once

#include <fcntl.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <string>

namespace quad_test {

struct RawPty {
  int master = -1, slave = -1;
  std::string path;  // empty if openpty failed
  explicit RawPty(bool nonblocking_master = false) {
    char name[256];
    if (openpty(&master, &slave, name, nullptr, nullptr) != 0) return;
    path = name;
    termios tio{};
    tcgetattr(master, &tio);
    cfmakeraw(&tio);
    tcsetattr(master, TCSANOW, &tio);
    tcsetattr(slave, TCSANOW, &tio);
    if (nonblocking_master) fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
  }
  ~RawPty() {
    if (master >= 0) close(master);
    if (slave >= 0) close(slave);
  }
  RawPty(const RawPty&) = delete;
  RawPty& operator=(const RawPty&) = delete;
};

}  // namespace quad_test
