#include "quad/vision/sim_socket.h"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <exception>
#include <thread>

namespace quad::vision {

SimSocket::SimSocket(const std::string& path, std::chrono::milliseconds connect_timeout, Raise raise)
    : path_(path), raise_(raise) {
  sockaddr_un address{};
  if (path.size() >= sizeof address.sun_path) fail("socket path too long");
  address.sun_family = AF_UNIX;
  std::memcpy(address.sun_path, path.c_str(), path.size());
  const auto deadline = std::chrono::steady_clock::now() + connect_timeout;
  for (;;) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) fail(std::string("socket: ") + std::strerror(errno));
    if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) break;
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    if (std::chrono::steady_clock::now() > deadline)
      fail(std::string("cannot connect to the simulator: ") + std::strerror(err));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

SimSocket::~SimSocket() {
  if (fd_ >= 0) ::close(fd_);
}

bool SimSocket::wait_readable(std::chrono::milliseconds timeout) {
  pollfd p{fd_, POLLIN, 0};
  return ::poll(&p, 1, static_cast<int>(timeout.count())) != 0;
}

bool SimSocket::receive(void* data, size_t length) {
  auto* p = static_cast<uint8_t*>(data);
  while (length > 0) {
    const ssize_t n = ::recv(fd_, p, length, 0);
    if (n == 0) return false;
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == ECONNRESET) return false;
      fail(std::strerror(errno));
    }
    p += n;
    length -= static_cast<size_t>(n);
  }
  return true;
}

bool SimSocket::send(const void* data, size_t length) {
  const auto* p = static_cast<const uint8_t*>(data);
  while (length > 0) {
    const ssize_t n = ::send(fd_, p, length, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    p += n;
    length -= static_cast<size_t>(n);
  }
  return true;
}

void SimSocket::fail(const std::string& what) const {
  raise_("sim:" + path_ + ": " + what);
  std::terminate();  // raise_ always throws
}

}  // namespace quad::vision
