#include "quad/sim/station_channel.h"

#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <thread>

namespace quad::sim {
namespace {

std::string socket_path_for_this_run(const std::string& prefix) {
  // Unix socket paths are limited to 108 bytes, so the socket lives in /tmp rather than the run folder.
  static std::atomic<int> counter{0};
  return "/tmp/" + prefix + "-" + std::to_string(getpid()) + "-" + std::to_string(counter++) + ".sock";
}

}  // namespace

StationChannel::StationChannel(const std::string& program, const std::string& socket_prefix)
    : program_(program), socket_path_(socket_path_for_this_run(socket_prefix)) {
  listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::memcpy(address.sun_path, socket_path_.c_str(), socket_path_.size());
  ::unlink(socket_path_.c_str());
  if (listen_fd_ < 0 || ::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 ||
      ::listen(listen_fd_, 1) != 0) {
    const int error = errno;
    if (listen_fd_ >= 0) ::close(listen_fd_);  // the destructor does not run for a throwing constructor
    throw StationError(socket_path_ + ": cannot listen for the " + program_ + ": " + std::strerror(error));
  }
}

StationChannel::~StationChannel() {
  finish();
  if (listen_fd_ >= 0) ::close(listen_fd_);
  ::unlink(socket_path_.c_str());
}

void StationChannel::start(const std::vector<std::string>& argv, const std::string& log_path) {
  log_name_ = std::filesystem::path(log_path).filename().string();
  process_ = std::make_unique<FirmwareProcess>(argv, log_path);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kAnswerTimeoutMs);
  while (fd_ < 0) {
    pollfd p{listen_fd_, POLLIN, 0};
    if (::poll(&p, 1, 100) > 0) fd_ = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
    if (fd_ >= 0) break;
    if (!process_->running())
      throw StationError("the " + program_ + " " + process_->status() + " before connecting (see " + log_path + ")");
    if (std::chrono::steady_clock::now() > deadline)
      throw StationError("the " + program_ + " did not connect to " + socket_path_ + " within 10 s");
  }
  // A station that is alive but stops reading must not hang the run: sends time out like answers do.
  const timeval send_timeout{kAnswerTimeoutMs / 1000, 0};
  ::setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &send_timeout, sizeof send_timeout);
}

void StationChannel::send_all(const void* data, size_t length, const char* what_is_sent) {
  const auto* p = static_cast<const uint8_t*>(data);
  while (length > 0) {
    // MSG_NOSIGNAL: a station that has gone is an error to report, not a SIGPIPE that ends the simulator.
    const ssize_t n = ::send(fd_, p, length, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw StationError(program_ + ": sending " + what_is_sent + " failed (" + std::strerror(errno) +
                         "): the station stopped reading for 10 s or has gone");
    }
    p += n;
    length -= static_cast<size_t>(n);
  }
}

void StationChannel::read_exact(void* data, size_t length, const char* what) {
  auto* p = static_cast<uint8_t*>(data);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kAnswerTimeoutMs);
  while (length > 0) {
    pollfd pfd{fd_, POLLIN, 0};
    if (::poll(&pfd, 1, 100) > 0) {
      const ssize_t n = ::recv(fd_, p, length, 0);
      if (n == 0) throw StationError("the " + program_ + " closed its socket while the simulator waited for " + what);
      if (n < 0 && errno != EINTR) throw StationError(program_ + " socket: " + std::strerror(errno));
      if (n > 0) {
        p += n;
        length -= static_cast<size_t>(n);
      }
      continue;
    }
    if (!process_->running()) throw StationError("the " + program_ + " " + process_->status() + " (see " + log_name_ + ")");
    if (std::chrono::steady_clock::now() > deadline)
      throw StationError("the " + program_ + " did not send " + what + " within 10 s");
  }
}

void StationChannel::finish() {
  if (fd_ >= 0) {
    ::close(fd_);  // the station's source sees the end of the stream and the station exits
    fd_ = -1;
    for (int i = 0; i < 100 && process_ && process_->running(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  process_.reset();
}

int StationChannel::pid() const {
  return process_ && process_->running() ? static_cast<int>(process_->pid()) : -1;
}

std::string default_station_calibration_cache(const std::vector<std::string>& station_argv, const std::string& out_dir) {
  // Beside the station executable (e.g. build/host/bin/station_calibration): shared by every run of that
  // build; a station found through PATH calibrates into the run folder.
  const std::string& exe = station_argv.empty() ? std::string() : station_argv.front();
  const size_t slash = exe.rfind('/');
  return slash == std::string::npos ? out_dir + "/station_calibration" : exe.substr(0, slash) + "/station_calibration";
}

}  // namespace quad::sim
