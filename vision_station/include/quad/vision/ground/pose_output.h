// What the ground-camera station sends each vehicle for a fix: VISION_POSITION_ESTIMATE (the field's
// external-position message: position in NED, ZYX Euler angles, the 6 × 6 pose covariance's upper
// triangle, `usec` the capture time), on that vehicle's radio port. `--message` selects the message; the
// full-pose ATT_POS_MOCAP joins the list when the firmware accepts it.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "quad/link/mavlink.h"
#include "quad/vision/fix_output.h"
#include "quad/vision/ground/marker_geometry.h"

namespace quad::vision::ground {

enum class PoseMessage { kVisionPositionEstimate };
// "vision_position_estimate"; throws std::runtime_error naming the word and the choices.
PoseMessage parse_pose_message(const std::string& word);

mavlink::VisionPositionEstimate vision_position_estimate(const RigidPose& pose, int64_t time_us);

// One radio port per vehicle: `spec` is "ID=PATH[,ID=PATH...]", or a single PATH for a single vehicle.
class PoseLinks {
 public:
  PoseLinks(const std::string& spec, int baud, const std::vector<int>& vehicle_ids, PoseMessage message);
  // False when the vehicle has no port or the port would not take the frame.
  bool send(int vehicle_id, const RigidPose& pose, int64_t time_us);
  uint64_t frames_sent() const { return sent_; }
  uint64_t frames_dropped() const { return dropped_; }

 private:
  std::map<int, std::unique_ptr<SerialPort>> ports_;
  PoseMessage message_;
  mavlink::Sender sender_;
  uint64_t sent_ = 0, dropped_ = 0;
};

}  // namespace quad::vision::ground
