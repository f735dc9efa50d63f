// The simulator's room cameras as a live source of `vision_station track` (`--source sim:SOCKET`): frame
// sets in lockstep over the wire of ground_sim_protocol.h, each answered after the set's fixes have gone
// out, so the simulator knows what to collect from the radio ports.
#pragma once

#include <chrono>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/ground/ground_sim_protocol.h"
#include "quad/vision/sim_socket.h"

namespace quad::vision::ground {

struct GroundSourceError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct GroundFrameSet {
  uint64_t sequence = 0;
  std::vector<cv::Mat> images;            // BGR, camera 0, 1, ...
  std::vector<int64_t> capture_time_us;   // per camera
};

class GroundSimSource {
 public:
  // Connects to the simulator's socket, retrying until `connect_timeout`; throws GroundSourceError.
  GroundSimSource(const std::string& path, std::chrono::milliseconds connect_timeout);
  GroundSimSource(const GroundSimSource&) = delete;
  GroundSimSource& operator=(const GroundSimSource&) = delete;

  // The next frame set; false at the end of the stream. Throws on a malformed header.
  bool read(GroundFrameSet& set);
  void answer(const ground_sim_protocol::SetAnswer& answer, const std::vector<ground_sim_protocol::VehicleReport>& reports);

 private:
  SimSocket socket_;
};

}  // namespace quad::vision::ground
