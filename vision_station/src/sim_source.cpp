#include "quad/vision/sim_source.h"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <thread>

#include "quad/vision/sim_protocol.h"

namespace quad::vision {
namespace {

namespace wire = sim_protocol;

class SimSource : public FrameSource {
 public:
  SimSource(const std::string& path, std::chrono::milliseconds connect_timeout) : path_(path) {
    sockaddr_un address{};
    if (path.size() >= sizeof address.sun_path) throw FrameSourceError("sim:" + path + ": socket path too long");
    address.sun_family = AF_UNIX;
    std::memcpy(address.sun_path, path.c_str(), path.size());
    const auto deadline = std::chrono::steady_clock::now() + connect_timeout;
    for (;;) {
      fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
      if (fd_ < 0) throw FrameSourceError("sim:" + path + ": socket: " + std::strerror(errno));
      if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) break;
      const int err = errno;
      ::close(fd_);
      fd_ = -1;
      if (std::chrono::steady_clock::now() > deadline) {
        throw FrameSourceError("sim:" + path + ": cannot connect to the simulator: " + std::strerror(err));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  ~SimSource() override {
    if (fd_ >= 0) ::close(fd_);
  }

  ReadStatus read(StereoFrame& frame, std::chrono::milliseconds timeout) override {
    if (ended_) return ReadStatus::kEnd;
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(timeout.count()));
    if (ready == 0) return ReadStatus::kNoFrame;
    wire::FrameHeader header;
    if (!receive(&header, sizeof header)) return end();
    if (header.magic != wire::kFrameMagic || header.width == 0 || header.height == 0 || header.width > 8192 ||
        header.height > 8192) {
      throw FrameSourceError("sim:" + path_ + ": malformed frame header (not a quad_sim camera stream?)");
    }
    const int w = static_cast<int>(header.width), h = static_cast<int>(header.height);
    frame.left.create(h, w, CV_8UC1);
    frame.right.create(h, w, CV_8UC1);
    if (!receive(frame.left.data, frame.left.total()) || !receive(frame.right.data, frame.right.total())) return end();
    frame.capture_time_us = header.capture_time_us;
    frame.sequence = header.sequence;
    frame.label.clear();
    answer_ = wire::FrameAnswer{};
    answer_.sequence = header.sequence;
    return ReadStatus::kFrame;
  }

  void processed(const StereoFrame&, double processing_us) override { answer_.processing_us = processing_us; }

  void answered(bool fix_found, uint64_t fixes_sent_total) override {
    answer_.fix_found = fix_found ? 1u : 0u;
    answer_.fixes_sent = fixes_sent_total;
    send_all(&answer_, sizeof answer_);
  }

  bool vehicle_clock() const override { return true; }
  std::string health() const override { return "sim:" + path_ + ": the simulator sent no frame"; }

 private:
  ReadStatus end() {
    ended_ = true;
    return ReadStatus::kEnd;
  }
  // False at the end of the stream (the simulator closed it).
  bool receive(void* data, size_t length) {
    auto* p = static_cast<uint8_t*>(data);
    while (length > 0) {
      const ssize_t n = ::recv(fd_, p, length, 0);
      if (n == 0) return false;
      if (n < 0) {
        if (errno == EINTR) continue;
        if (errno == ECONNRESET) return false;
        throw FrameSourceError("sim:" + path_ + ": " + std::strerror(errno));
      }
      p += n;
      length -= static_cast<size_t>(n);
    }
    return true;
  }
  void send_all(const void* data, size_t length) {
    const auto* p = static_cast<const uint8_t*>(data);
    while (length > 0) {
      const ssize_t n = ::send(fd_, p, length, MSG_NOSIGNAL);
      if (n < 0) {
        if (errno == EINTR) continue;
        ended_ = true;  // the simulator has gone
        return;
      }
      p += n;
      length -= static_cast<size_t>(n);
    }
  }

  std::string path_;
  int fd_ = -1;
  bool ended_ = false;
  wire::FrameAnswer answer_;
};

}  // namespace

std::unique_ptr<FrameSource> make_sim_source(const std::string& path, std::chrono::milliseconds connect_timeout) {
  return std::make_unique<SimSource>(path, connect_timeout);
}

}  // namespace quad::vision
