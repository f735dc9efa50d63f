// Test scenes for the vision station: shapes on a floor plane rendered through the thesis camera model
// (forward OpenCV distortion) with anti-aliasing by supersampling, lighting, blur and sensor noise.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/thesis_rig.h"

namespace quad::vision::testing {

// A polygon on the floor plane (floor coordinates x, y in metres) with its albedo (grey 0..255).
struct FloorShape {
  std::vector<cv::Point2d> outline;
  double grey = 40.0;
};

// A soft shadow: the floor's lighting inside the polygon is multiplied by `factor`.
struct FloorShadow {
  std::vector<cv::Point2d> outline;
  double factor = 0.5;
};

struct RenderOptions {
  int supersample = 4;            // anti-aliasing: sub-pixels per pixel side
  double floor_grey = 205.0;      // albedo of the floor
  double gradient = 0.0;          // uneven lighting: darkening fraction across the image
  double gradient_angle = 0.0;    // direction of the gradient in the image, radians
  std::vector<FloorShadow> shadows;
  double shadow_blur_px = 6.0;    // soft shadow edges
  double blur_sigma_px = 0.6;     // lens and composite-video blur
  double noise_sigma = 3.0;       // additive Gaussian sensor noise, grey levels
  double salt_pepper_fraction = 0.0;
};

// Floor-to-camera pose: p_camera = R·p_floor + t, the floor being the plane z = 0.
struct Pose {
  cv::Matx33d R;
  cv::Vec3d t;
};

// The undistorted normalised radius beyond which the radial polynomial folds back (d r_d / d r_u = 0):
// the thesis lenses' model is only valid inside it.
double max_valid_radius(const CameraIntrinsics& camera);

// Projects a floor point; nullopt when behind the camera or outside 0.97 of the valid radius.
std::optional<cv::Point2d> project(const CameraIntrinsics& camera, const Pose& pose, const cv::Point2d& floor_point);

// Every point of the densified outline projects validly and lies at least `margin_px` inside the image.
bool fully_visible(const CameraIntrinsics& camera, cv::Size size, const Pose& pose,
                   const std::vector<cv::Point2d>& outline, double margin_px);

// Renders one camera's view (CV_8UC1). nullopt when a shape cannot be projected validly.
std::optional<cv::Mat> render_view(const CameraIntrinsics& camera, cv::Size size, const Pose& pose,
                                   const std::vector<FloorShape>& shapes, const RenderOptions& options, cv::RNG& rng);

// The right camera's pose from the left one: x_right = R x_left + T.
Pose right_pose(const StereoRig& rig, const Pose& left);

// A floor circle / regular polygon / square as outlines (metres).
std::vector<cv::Point2d> regular_polygon(cv::Point2d centre, double radius, int sides, double rotation);

// Pose of a camera `height` metres above the floor plane (perpendicular distance), tilted by `tilt`
// about an axis at `tilt_azimuth` in the image plane, with the floor point `target` on the ray through
// the undistorted normalised image point `ray`, and the floor's x axis at `yaw` in the image.
Pose camera_pose(double height, double tilt, double tilt_azimuth, double yaw, cv::Point2d ray, cv::Point2d target);

}  // namespace quad::vision::testing
