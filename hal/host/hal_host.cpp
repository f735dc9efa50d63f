// Host HAL: termios raw serial ports, CLOCK_MONOTONIC, file-backed parameter storage.
#include "quad/hal/host.h"

#include "quad/hal/termios_speed.h"

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>


namespace quad {
namespace hal {
namespace host {
namespace {

struct PortState {
  int fd = -1;
  bool hangup_seen = false;  // poll() reported POLLHUP; bytes may still wait to be read
  bool hung_up = false;      // ... and they have been read: the port is gone
  uint32_t dropped = 0;
  uint32_t baud = 0;
  double queued_bytes = 0.0;  // a modelled transmit queue, drained at baud / 10 bytes per second
  double queued_at_s = 0.0;
};

struct State {
  PortState ports[kPortCount];
  uint8_t storage[kStorageSize];
  int storage_fd = -1;
  bool led = false;
  timespec epoch{};
};

State g_state;

std::string system_error(const std::string& what, const std::string& path) {
  return what + " '" + path + "': " + strerror(errno);
}

bool open_port(const PortConfig& config, const char* name, PortState* port, std::string* error) {
  speed_t speed;
  if (!quad::hal::termios_speed(config.baud, &speed)) {
    *error = std::string(name) + ": unsupported baud rate " + std::to_string(config.baud) +
             " (use a standard rate such as 57600, 115200 or 921600)";
    return false;
  }
  const int fd = ::open(config.path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    *error = system_error(std::string(name) + ": cannot open serial port", config.path);
    return false;
  }
  termios tio;
  if (tcgetattr(fd, &tio) != 0) {
    *error = system_error(std::string(name) + ": not a serial port", config.path);
    ::close(fd);
    return false;
  }
  cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  if (cfsetispeed(&tio, speed) != 0 || cfsetospeed(&tio, speed) != 0 || tcsetattr(fd, TCSANOW, &tio) != 0) {
    *error = system_error(std::string(name) + ": cannot configure serial port", config.path);
    ::close(fd);
    return false;
  }
  // No flush: bytes a simulator wrote to its pseudo-terminal before we opened it are the start of
  // the session (the parser resynchronises on anything else).
  port->fd = fd;
  port->baud = config.baud;
  port->hung_up = false;
  port->dropped = 0;
  return true;
}

// The storage file holds exactly kStorageSize bytes; a new file starts erased, like a new EEPROM.
bool open_storage(const std::string& path, std::string* error) {
  memset(g_state.storage, 0xFF, sizeof g_state.storage);
  if (path.empty()) return true;
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    *error = system_error("cannot open parameter storage", path);
    return false;
  }
  const ssize_t n = pread(fd, g_state.storage, sizeof g_state.storage, 0);
  if (n < 0) {
    *error = system_error("cannot read parameter storage", path);
    ::close(fd);
    return false;
  }
  if (n < static_cast<ssize_t>(sizeof g_state.storage)) {
    // A short (or new) file: the missing tail is erased memory; write it out so the size is right.
    if (pwrite(fd, g_state.storage + n, sizeof g_state.storage - static_cast<size_t>(n), n) < 0) {
      *error = system_error("cannot write parameter storage", path);
      ::close(fd);
      return false;
    }
  }
  g_state.storage_fd = fd;
  return true;
}

}  // namespace

bool baud_supported(uint32_t baud) {
  speed_t unused;
  return quad::hal::termios_speed(baud, &unused);
}

bool open(const Config& config, std::string* error) {
  close();
  static const char* const kNames[kPortCount] = {"uart0", "uart2"};
  for (int i = 0; i < kPortCount; ++i) {
    if (config.ports[i].path.empty()) continue;
    if (!open_port(config.ports[i], kNames[i], &g_state.ports[i], error)) {
      close();
      return false;
    }
  }
  if (!open_storage(config.storage_path, error)) {
    close();
    return false;
  }
  clock_gettime(CLOCK_MONOTONIC, &g_state.epoch);
  return true;
}

void close() {
  for (PortState& port : g_state.ports) {
    if (port.fd >= 0) ::close(port.fd);
    port = PortState{};
  }
  if (g_state.storage_fd >= 0) ::close(g_state.storage_fd);
  g_state.storage_fd = -1;
}

bool port_hung_up(Port port) { return g_state.ports[port].hung_up; }
uint32_t bytes_dropped(Port port) { return g_state.ports[port].dropped; }
bool led_state() { return g_state.led; }

}  // namespace host

void init() {}

uint32_t micros() {
  timespec now;
  clock_gettime(CLOCK_MONOTONIC, &now);
  const int64_t us = (static_cast<int64_t>(now.tv_sec) - host::g_state.epoch.tv_sec) * 1000000 +
                     (now.tv_nsec - host::g_state.epoch.tv_nsec) / 1000;
  return static_cast<uint32_t>(us);
}

void idle(uint32_t max_wait_us) {
  pollfd fds[kPortCount];
  host::PortState* polled[kPortCount];
  nfds_t n = 0;
  for (auto& port : host::g_state.ports) {
    if (port.fd < 0 || port.hung_up) continue;
    polled[n] = &port;
    fds[n++] = pollfd{port.fd, POLLIN, 0};
  }
  if (n == 0) {
    timespec wait{static_cast<time_t>(max_wait_us / 1000000u), static_cast<long>(max_wait_us % 1000000u) * 1000};
    nanosleep(&wait, nullptr);
    return;
  }
  const int timeout_ms = static_cast<int>((max_wait_us + 999u) / 1000u);
  if (poll(fds, n, timeout_ms) <= 0) return;
  // A hung-up terminal (the pseudo-terminal's master closed, the adapter unplugged) reports POLLHUP;
  // its reads return 0 forever, which raw mode (VMIN = 0) cannot tell from "no data".
  for (nfds_t i = 0; i < n; ++i) {
    if ((fds[i].revents & (POLLHUP | POLLERR | POLLNVAL)) != 0) polled[i]->hangup_seen = true;
  }
}

uint16_t serial_read(Port port, uint8_t* dst, uint16_t capacity) {
  host::PortState& state = host::g_state.ports[port];
  if (state.fd < 0 || state.hung_up || capacity == 0) return 0;
  const ssize_t n = ::read(state.fd, dst, capacity);
  if (n > 0) return static_cast<uint16_t>(n);
  // In raw mode with VMIN = 0 a read of 0 bytes only means "nothing waiting"; hang-ups are seen by
  // idle() (POLLHUP) or here as an error such as EIO.
  if ((n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) || (n == 0 && state.hangup_seen)) {
    state.hung_up = true;
  }
  return 0;
}

namespace host {
namespace {
// A pseudo-terminal takes bytes at any rate; a UART at the port's baud with a 128-byte queue (the AVR's
// radio ring) would not: the queue modelled here is what serial_tx_free() reports.
constexpr double kTxQueueBytes = 128.0;
double seconds_now() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
void drain(PortState& state) {
  const double now = seconds_now();
  if (state.baud > 0) state.queued_bytes -= (now - state.queued_at_s) * state.baud / 10.0;
  if (state.queued_bytes < 0.0 || state.baud == 0) state.queued_bytes = 0.0;
  state.queued_at_s = now;
}
}  // namespace
}  // namespace host

uint16_t serial_tx_free(Port port) {
  host::PortState& state = host::g_state.ports[port];
  host::drain(state);
  const double room = host::kTxQueueBytes - state.queued_bytes;
  return room > 0.0 ? static_cast<uint16_t>(room) : 0;
}

uint16_t serial_write(Port port, const uint8_t* src, uint16_t length) {
  host::PortState& state = host::g_state.ports[port];
  host::drain(state);
  state.queued_bytes += length;
  if (state.fd < 0 || state.hung_up) {
    state.dropped += length;
    return 0;
  }
  const ssize_t n = ::write(state.fd, src, length);
  const uint16_t written = n > 0 ? static_cast<uint16_t>(n) : 0;
  if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) state.hung_up = true;
  state.dropped += static_cast<uint32_t>(length - written);
  return written;
}

uint16_t storage_size() { return host::kStorageSize; }

bool storage_read(uint16_t offset, void* dst, uint16_t length) {
  if (static_cast<uint32_t>(offset) + length > host::kStorageSize) return false;
  memcpy(dst, host::g_state.storage + offset, length);
  return true;
}

bool storage_write(uint16_t offset, const void* src, uint16_t length) {
  if (static_cast<uint32_t>(offset) + length > host::kStorageSize) return false;
  memcpy(host::g_state.storage + offset, src, length);
  if (host::g_state.storage_fd < 0) return true;
  return pwrite(host::g_state.storage_fd, src, length, offset) == static_cast<ssize_t>(length) &&
         fdatasync(host::g_state.storage_fd) == 0;
}

void led_write(bool on) { host::g_state.led = on; }

void trace(TracePoint) {}  // the host firmware is profiled with the host's own tools

}  // namespace hal
}  // namespace quad
