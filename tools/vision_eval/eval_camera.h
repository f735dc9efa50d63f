// The evaluation generator's own camera model: OpenCV's pinhole + radial/tangential lens (projection by
// cv::projectPoints), a stereo rig of two such cameras, and the rendering of a textured plane seen by one
// of them. Deliberately shares nothing with the vision station's rig, lens or star code: it is the
// independent oracle the station is measured against.
#pragma once

#include <opencv2/core.hpp>

namespace vision_eval {

struct EvalCamera {
  cv::Size size;
  cv::Matx33d K;
  cv::Vec<double, 5> D;  // k1 k2 p1 p2 k3
};

// x_right = R·x_left + T (metres, OpenCV camera axes).
struct EvalRig {
  EvalCamera left, right;
  cv::Matx33d R;
  cv::Vec3d T;
};

// An analog FPV stereo head: 720 × 480 (NTSC active area), wide lenses with barrel distortion, 0.12 m
// baseline, the two cameras slightly mis-aligned as mounted by hand.
EvalRig fpv_rig();

// A rigid pose of a camera relative to a plane's frame (the plane is z = 0 of that frame):
// p_camera = R_cp·(p_plane − C).
struct CameraPose {
  cv::Matx33d R_cp;
  cv::Vec3d C;
};

// The right camera's pose given the left one's.
CameraPose right_pose(const EvalRig& rig, const CameraPose& left);

// Pixel positions of plane points (plane z = 0) by cv::projectPoints.
std::vector<cv::Point2f> project(const EvalCamera& camera, const CameraPose& pose,
                                 const std::vector<cv::Point3d>& plane_points);

// For every pixel of an image supersampled `factor` times, the undistorted normalised ray (x, y, 1), found
// once per camera with cv::undistortPoints and checked against cv::projectPoints (throws when the lens
// inversion is off by more than 0.01 px anywhere).
class RayGrid {
 public:
  RayGrid(const EvalCamera& camera, int factor);
  // Plane coordinates (metres) hit by each ray; NaN where the ray misses the plane (behind the camera).
  void plane_hits(const CameraPose& pose, cv::Mat& x, cv::Mat& y) const;
  cv::Size size() const { return rays_x_.size(); }

 private:
  cv::Mat rays_x_, rays_y_;  // CV_32F
};

}  // namespace vision_eval
