#include "quad/vision/ground/pose_output.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace quad::vision::ground {

PoseMessage parse_pose_message(const std::string& word) {
  if (word == "vision_position_estimate") return PoseMessage::kVisionPositionEstimate;
  throw std::runtime_error("--message '" + word + "': expected vision_position_estimate");
}

mavlink::VisionPositionEstimate vision_position_estimate(const RigidPose& pose, int64_t time_us) {
  mavlink::VisionPositionEstimate m;
  m.usec = static_cast<uint64_t>(time_us);
  m.x = static_cast<float>(pose.position_ned[0]);
  m.y = static_cast<float>(pose.position_ned[1]);
  m.z = static_cast<float>(pose.position_ned[2]);
  const cv::Matx33d& R = pose.R_IB;  // ZYX Euler angles of q_IB
  m.roll = static_cast<float>(std::atan2(R(2, 1), R(2, 2)));
  m.pitch = static_cast<float>(-std::asin(std::max(-1.0, std::min(1.0, R(2, 0)))));
  m.yaw = static_cast<float>(std::atan2(R(1, 0), R(0, 0)));
  // Upper triangle, row-major, of the 6 × 6 covariance of (x, y, z, roll, pitch, yaw); the attitude
  // block is the small rotation about the NED axes, which near level equals roll, pitch, yaw.
  int k = 0;
  for (int i = 0; i < 6; ++i)
    for (int j = i; j < 6; ++j) {
      double c = 0.0;
      if (i < 3 && j < 3) c = pose.position_covariance(i, j);
      if (i >= 3 && j >= 3) c = pose.attitude_covariance(i - 3, j - 3);
      m.covariance[k++] = static_cast<float>(c);
    }
  return m;
}

PoseLinks::PoseLinks(const std::string& spec, int baud, const std::vector<int>& vehicle_ids, PoseMessage message)
    : message_(message), sender_(1, mavlink::kCompIdVisualInertialOdometry) {
  if (spec.find('=') == std::string::npos) {
    if (vehicle_ids.size() != 1)
      throw std::runtime_error("--radio '" + spec + "': several vehicles need ID=PATH for each (e.g. 1=/dev/pts/3,2=/dev/pts/4)");
    ports_[vehicle_ids.front()] = std::make_unique<SerialPort>(spec, baud);
    return;
  }
  std::stringstream items(spec);
  for (std::string item; std::getline(items, item, ',');) {
    const size_t eq = item.find('=');
    int id = 0;
    try {
      id = std::stoi(item.substr(0, eq));
    } catch (const std::exception&) {
      throw std::runtime_error("--radio '" + item + "': expected ID=PATH");
    }
    if (eq == std::string::npos || eq + 1 >= item.size()) throw std::runtime_error("--radio '" + item + "': expected ID=PATH");
    if (std::find(vehicle_ids.begin(), vehicle_ids.end(), id) == vehicle_ids.end())
      throw std::runtime_error("--radio '" + item + "': vehicle " + std::to_string(id) + " is not in the vehicles file");
    ports_[id] = std::make_unique<SerialPort>(item.substr(eq + 1), baud);
  }
}

bool PoseLinks::send(int vehicle_id, const RigidPose& pose, int64_t time_us) {
  const auto it = ports_.find(vehicle_id);
  if (it == ports_.end()) return false;
  uint8_t out[mavlink::kMaxFrameLength];
  size_t n = 0;
  switch (message_) {
    case PoseMessage::kVisionPositionEstimate: n = sender_.encode(vision_position_estimate(pose, time_us), out, sizeof out); break;
  }
  if (n > 0 && it->second->write_all(out, n)) {
    ++sent_;
    return true;
  }
  ++dropped_;
  return false;
}

}  // namespace quad::vision::ground
