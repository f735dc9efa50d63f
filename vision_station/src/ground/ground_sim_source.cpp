#include "quad/vision/ground/ground_sim_source.h"

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <thread>

namespace quad::vision::ground {

namespace wire = ground_sim_protocol;

GroundSimSource::GroundSimSource(const std::string& path, std::chrono::milliseconds connect_timeout) : path_(path) {
  sockaddr_un address{};
  if (path.size() >= sizeof address.sun_path) throw GroundSourceError("sim:" + path + ": socket path too long");
  address.sun_family = AF_UNIX;
  std::memcpy(address.sun_path, path.c_str(), path.size());
  const auto deadline = std::chrono::steady_clock::now() + connect_timeout;
  for (;;) {
    fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) throw GroundSourceError("sim:" + path + ": socket: " + std::strerror(errno));
    if (::connect(fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) break;
    const int err = errno;
    ::close(fd_);
    fd_ = -1;
    if (std::chrono::steady_clock::now() > deadline)
      throw GroundSourceError("sim:" + path + ": cannot connect to the simulator: " + std::strerror(err));
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

GroundSimSource::~GroundSimSource() {
  if (fd_ >= 0) ::close(fd_);
}

bool GroundSimSource::read(GroundFrameSet& set) {
  wire::SetHeader header;
  if (!receive(&header, sizeof header)) return false;
  if (header.magic != wire::kSetMagic || header.cameras < 2 || header.cameras > wire::kMaxCameras || header.width == 0 ||
      header.height == 0 || header.width > 8192 || header.height > 8192)
    throw GroundSourceError("sim:" + path_ + ": malformed frame-set header (not a quad_sim room-camera stream?)");
  set.sequence = header.sequence;
  set.images.resize(header.cameras);
  set.capture_time_us.assign(header.capture_time_us, header.capture_time_us + header.cameras);
  for (cv::Mat& image : set.images) {
    image.create(static_cast<int>(header.height), static_cast<int>(header.width), CV_8UC3);
    if (!receive(image.data, image.total() * image.elemSize())) return false;
  }
  return true;
}

void GroundSimSource::answer(const wire::SetAnswer& answer, const std::vector<wire::VehicleReport>& reports) {
  const auto* head = reinterpret_cast<const uint8_t*>(&answer);
  const auto* body = reinterpret_cast<const uint8_t*>(reports.data());
  std::vector<uint8_t> bytes(head, head + sizeof answer);
  bytes.insert(bytes.end(), body, body + reports.size() * sizeof(wire::VehicleReport));
  const uint8_t* p = bytes.data();
  size_t length = bytes.size();
  while (length > 0) {
    const ssize_t n = ::send(fd_, p, length, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      return;  // the simulator has gone: the next read ends the source
    }
    p += n;
    length -= static_cast<size_t>(n);
  }
}

bool GroundSimSource::receive(void* data, size_t length) {
  auto* p = static_cast<uint8_t*>(data);
  while (length > 0) {
    const ssize_t n = ::recv(fd_, p, length, 0);
    if (n == 0) return false;
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno == ECONNRESET) return false;
      throw GroundSourceError("sim:" + path_ + ": " + std::strerror(errno));
    }
    p += n;
    length -= static_cast<size_t>(n);
  }
  return true;
}

}  // namespace quad::vision::ground
