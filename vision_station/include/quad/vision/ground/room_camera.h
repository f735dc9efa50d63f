// Fixed ground cameras calibrated to the room (seed 003 sec. 3.1): each camera's intrinsics, lens
// distortion and pose in the room's NED frame, giving the projection matrix P = K [R_I^cam | t_I^cam]
// (seed 003 eq. 3.2) that maps a room point to pixels (seed 003 eq. 3.1).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace quad::vision::ground {

// One camera: x_cam = R_CI·x_NED + t_CI (OpenCV camera axes), pixels through K and D.
struct RoomCamera {
  cv::Size image_size;
  cv::Matx33d K = cv::Matx33d::eye();
  cv::Vec<double, 5> D = cv::Vec<double, 5>::all(0.0);  // k1, k2, p1, p2, k3
  cv::Matx33d R_CI = cv::Matx33d::eye();
  cv::Vec3d t_CI;

  cv::Matx34d projection() const;  // seed 003 eq. 3.2 (pixels of the undistorted image)
  cv::Vec3d centre_ned() const;    // the optical centre in the room
  // Distortion removed, still in pixels (the frame of projection()).
  std::vector<cv::Point2d> undistort(const std::vector<cv::Point2d>& pixels) const;
};

// The cameras of one room rig, in a fixed order (camera 0, 1, ...).
struct RoomRig {
  std::vector<RoomCamera> cameras;
};

// Fundamental matrix from camera a's undistorted pixels to camera b's: x_bᵀ F x_a = 0 (seed 003 eq. 3.3).
cv::Matx33d fundamental(const RoomCamera& a, const RoomCamera& b);

// OpenCV FileStorage (YAML): cameras (count), then camera_N_{image_size,K,D,R_CI,t_CI,P} per camera.
void save_room_rig(const RoomRig& rig, const std::string& path);
// Errors name the file and the missing or malformed key.
RoomRig load_room_rig(const std::string& path);

}  // namespace quad::vision::ground
