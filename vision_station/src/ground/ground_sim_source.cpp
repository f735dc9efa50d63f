#include "quad/vision/ground/ground_sim_source.h"

namespace quad::vision::ground {

namespace wire = ground_sim_protocol;

GroundSimSource::GroundSimSource(const std::string& path, std::chrono::milliseconds connect_timeout)
    : socket_(SimSocket::connect<GroundSourceError>(path, connect_timeout)) {}

bool GroundSimSource::read(GroundFrameSet& set) {
  wire::SetHeader header;
  if (!socket_.receive(&header, sizeof header)) return false;
  if (header.magic != wire::kSetMagic || header.cameras < 2 || header.cameras > wire::kMaxCameras || header.width == 0 ||
      header.height == 0 || header.width > 8192 || header.height > 8192)
    throw GroundSourceError("sim:" + socket_.path() +
                            ": malformed frame-set header (not a quad_sim room-camera stream?)");
  set.sequence = header.sequence;
  set.images.resize(header.cameras);
  set.capture_time_us.assign(header.capture_time_us, header.capture_time_us + header.cameras);
  for (cv::Mat& image : set.images) {
    image.create(static_cast<int>(header.height), static_cast<int>(header.width), CV_8UC3);
    if (!socket_.receive(image.data, image.total() * image.elemSize())) return false;
  }
  return true;
}

void GroundSimSource::answer(const wire::SetAnswer& answer, const std::vector<wire::VehicleReport>& reports) {
  const auto* head = reinterpret_cast<const uint8_t*>(&answer);
  const auto* body = reinterpret_cast<const uint8_t*>(reports.data());
  std::vector<uint8_t> bytes(head, head + sizeof answer);
  bytes.insert(bytes.end(), body, body + reports.size() * sizeof(wire::VehicleReport));
  socket_.send(bytes.data(), bytes.size());  // if the simulator has gone, the next read ends the source
}

}  // namespace quad::vision::ground
