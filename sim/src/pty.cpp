#include "quad/sim/pty.h"

#include "quad/hal/termios_speed.h"

#include <cerrno>
#include <cstring>
#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <sys/ioctl.h>
#include <stdexcept>
#include <termios.h>
#include <unistd.h>

namespace quad::sim {
namespace {

speed_t speed_constant(int baud) {
  speed_t speed;
  if (baud <= 0 || !hal::termios_speed(static_cast<uint32_t>(baud), &speed)) {
    throw std::invalid_argument("unsupported baud rate " + std::to_string(baud));
  }
  return speed;
}

void make_raw(int fd, speed_t speed) {
  termios tio{};
  if (tcgetattr(fd, &tio) != 0) throw std::runtime_error(std::string("tcgetattr: ") + std::strerror(errno));
  cfmakeraw(&tio);
  cfsetispeed(&tio, speed);
  cfsetospeed(&tio, speed);
  if (tcsetattr(fd, TCSANOW, &tio) != 0) throw std::runtime_error(std::string("tcsetattr: ") + std::strerror(errno));
}

}  // namespace

Pty::Pty(int baud) {
  char name[256] = "";
  if (openpty(&master_, &slave_, name, nullptr, nullptr) != 0)
    throw std::runtime_error(std::string("openpty: ") + std::strerror(errno));
  slave_path_ = name;
  const speed_t speed = speed_constant(baud);
  make_raw(master_, speed);
  make_raw(slave_, speed);
  fcntl(master_, F_SETFL, fcntl(master_, F_GETFL) | O_NONBLOCK);
  fcntl(master_, F_SETFD, FD_CLOEXEC);
  fcntl(slave_, F_SETFD, FD_CLOEXEC);
}

Pty::~Pty() {
  if (master_ >= 0) close(master_);
  if (slave_ >= 0) close(slave_);
}

void Pty::write_all(const uint8_t* data, size_t length) {
  while (length > 0) {
    const ssize_t n = write(master_, data, length);
    if (n > 0) {
      data += n;
      length -= static_cast<size_t>(n);
    } else if (n < 0 && errno != EAGAIN && errno != EINTR) {
      throw std::runtime_error(slave_path_ + ": write: " + std::strerror(errno));
    } else {
      pollfd p{master_, POLLOUT, 0};
      poll(&p, 1, 10);
    }
  }
}

size_t Pty::write_or_drop(const uint8_t* data, size_t length) {
  while (length > 0) {
    const ssize_t n = write(master_, data, length);
    if (n > 0) {
      data += n;
      length -= static_cast<size_t>(n);
    } else if (n < 0 && errno == EINTR) {
      continue;
    } else {
      break;  // full (EAGAIN) or no reader: the rest is lost
    }
  }
  return length;
}

size_t Pty::read_some(uint8_t* out, size_t capacity) {
  const ssize_t n = read(master_, out, capacity);
  if (n > 0) return static_cast<size_t>(n);
  // EIO: no process has the slave open right now (the sim keeps its own slave fd, so only transiently).
  if (n < 0 && errno != EAGAIN && errno != EINTR && errno != EIO)
    throw std::runtime_error(slave_path_ + ": read: " + std::strerror(errno));
  return 0;
}

bool Pty::wait_readable(int timeout_ms) const {
  pollfd p{master_, POLLIN, 0};
  return poll(&p, 1, timeout_ms) > 0 && (p.revents & POLLIN);
}

}  // namespace quad::sim

namespace quad::sim {

int Pty::unread_by_peer() const {
  pollfd p{slave_, POLLIN, 0};
  poll(&p, 1, 0);  // n_tty_poll flushes the pending flip buffer into the slave's input queue
  int n = 0;
  return ioctl(slave_, FIONREAD, &n) == 0 ? n : 0;
}

}  // namespace quad::sim
