// The vehicle's two downward cameras, rendered: the floor plane with the four-pointed star at
// the NED origin and distractor shapes, seen through the thesis' stereo rig (table 7.1 intrinsics with
// their lens distortion, eq. 7.22 mount, eq. 7.34 relative rotation) — the same OpenCV camera model the
// vision station undistorts with (quad/vision/thesis_rig.h), so its undistortion is exercised exactly.
//
// The cameras see only the floor (they look straight down between the landing gear), so each view is
// rendered exactly rather than rasterised by OpenGL: every floor shape's outline is projected through
// the distorting camera model and filled with 4 × 4 supersampling (anti-aliased edges at true sub-pixel
// positions), then lighting fall-off, the frame's exposure and Gaussian sensor noise are applied.
// A 728 × 488 pair costs about 1.4 ms of CPU this way (bench_sim BM_RenderStereoPair); the OSMesa
// (llvmpipe) chase-camera recorder took about 0.1 s per 640 × 360 frame in the same flight.
#pragma once

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "quad/sim/rng.h"
#include "quad/sim/scenario.h"
#include "quad/vision/thesis_rig.h"

namespace quad::sim {


// A dark shape on the floor: outline in NED metres (north, east) on the plane d = 0, and its albedo.
struct FloorShape {
  std::vector<Eigen::Vector2d> outline;
  double grey = 40.0;
};

// The star at the origin (shapes[0], tips along north and east) and `distractors` shapes 0.5 to 2.5 m
// away that do not overlap it or each other, placed by `rng`.
std::vector<FloorShape> make_floor_scene(const CameraParams& params, Rng rng);

// One camera's pose: p_camera = R · p_ned + t (OpenCV camera axes: x right, y down, z along the view).
struct CameraPose {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
};

// Left camera from the vehicle's NED position and attitude through the mount (eq. 7.22:
// p_B = R_BC p_C + t_BC); right camera from the left through the rig (x_right = R x_left + T).
CameraPose left_camera_pose(const quad::vision::CameraMount& mount, const Eigen::Vector3d& p_ned,
                            const Eigen::Quaterniond& q_ib);
CameraPose right_camera_pose(const quad::vision::StereoRig& rig, const CameraPose& left);

// Projects a camera-frame point through the camera model (forward OpenCV radial distortion). Points
// beyond the radius where the lens polynomial folds back are pulled in radially onto 0.97 of it (they
// lie outside the image anyway); nullopt behind the camera.
std::optional<cv::Point2d> project_point(const quad::vision::CameraIntrinsics& camera, double valid_radius,
                                         const Eigen::Vector3d& p_camera);

// The undistorted normalised radius at which r·(1 + k1 r² + k2 r⁴ + k3 r⁶) stops growing.
double fold_radius(const quad::vision::CameraIntrinsics& camera);

class StereoCameraRenderer {
 public:
  StereoCameraRenderer(const CameraParams& params, std::vector<FloorShape> scene, Rng rng);

  // Renders both views (CV_8UC1, the rig's image size) of the vehicle at p_ned / q_ib. With `hide_star`
  // the marker is not drawn (a star covered or out of sight: the vision_dropout fault).
  void render(const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool hide_star, cv::Mat& left,
              cv::Mat& right);

  // A second star-like shape, the star's copy centred at `north_east` (m), drawn from now on; nullopt
  // removes it (fault campaign: a decoy entering the view).
  void set_decoy(const std::optional<Eigen::Vector2d>& north_east);

  const quad::vision::StereoRig& rig() const { return rig_; }
  const std::vector<FloorShape>& scene() const { return scene_; }

 private:
  void render_view(const quad::vision::CameraIntrinsics& camera, double valid_radius, const CameraPose& pose,
                   bool hide_star, double exposure, const cv::Mat& lighting, cv::Mat& out);

  CameraParams p_;
  std::vector<FloorShape> scene_;
  size_t scene_shapes_;  // the scene without the decoy
  Rng rng_;
  quad::vision::StereoRig rig_;
  quad::vision::CameraMount mount_;
  double valid_left_, valid_right_;
  cv::Mat lighting_left_, lighting_right_;  // CV_32F vignetting, per pixel
  std::vector<int8_t> noise_;               // a table of Gaussian samples, read from a random offset per view
  double exposure_walk_ = 0.0;
  cv::Mat albedo_, canvas_, coverage_;      // work buffers
};

}  // namespace quad::sim
