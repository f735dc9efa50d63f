// The fixed room cameras of the ground-camera mode (seed 003 sec. 3 and table 6.1), rendered by the
// simulator itself: each camera's lens is the simulator's own model (quad/sim/camera_model.h), its pose
// in the room follows from the scenario's `ground_cameras` keys, and the vehicles it sees are drawn
// with a depth test per sample: each vehicle's four colour balls (red, green, blue, yellow, shaded by a
// light from above) and its dark hub and arms, which hide balls behind them, as do other vehicles and
// balls. The rotors are not drawn (spinning discs are nearly transparent). The room is a floor of grey
// tiles and grey walls. Light and sensor: an illumination gain wandering over time, a brightness ramp
// across the image, a colour cast per camera and Gaussian noise (drawn from a bank of noise images,
// shifted per frame).
//
// The renderer knows nothing of how many vehicles a scenario flies: it draws the list it is given.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "quad/sim/camera_model.h"
#include "quad/sim/ground_camera_params.h"
#include "quad/sim/rng.h"
#include "quad/sim/stereo_camera.h"

namespace quad::sim {

inline constexpr int kMarkerColourCount = 4;  // red, green, blue, yellow

// One room camera: x_cam = R_CI · x_NED + t_CI (OpenCV camera axes), pixels through `lens`.
struct GroundCamera {
  int width = 1024, height = 768;
  LensParams lens;
  Eigen::Matrix3d R_CI = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_CI = Eigen::Vector3d::Zero();
  Eigen::Vector3d centre_ned() const { return -R_CI.transpose() * t_CI; }
};

// The cameras of the scenario: camera k at bearing first_azimuth + k · spacing from the centre, at
// `distance_m` and `height_m`, looking at the point `aim_height_m` above the centre, level (no roll).
std::vector<GroundCamera> ground_cameras_from(const GroundCameraParams& params);

// One vehicle as the room cameras see it: its pose and its markers (body FRD, metres).
struct MarkedVehicle {
  int id = 1;
  Eigen::Vector3d p_ned = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_ib = Eigen::Quaterniond::Identity();
  std::array<Eigen::Vector3d, kMarkerColourCount> markers_frd;
  double marker_radius_m = 0.02;
};

// What a camera shows of one marker: the projection of the ball's centre and the fraction of the
// ball's samples not hidden by something nearer (0 outside the image).
struct MarkerView {
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  double radius_px = 0.0;
  double visible = 0.0;
};
// [vehicle][colour]
using MarkerViews = std::vector<std::array<MarkerView, kMarkerColourCount>>;

class GroundCameraRenderer {
 public:
  GroundCameraRenderer(const GroundCameraParams& params, std::vector<GroundCamera> cameras, Rng rng);

  // Camera k's image (CV_8UC3, BGR) of `vehicles` at simulated time t; the markers' views into `views`
  // when given.
  void render(size_t camera, const std::vector<MarkedVehicle>& vehicles, double t, cv::Mat& bgr,
              MarkerViews* views = nullptr);

  // Camera k's image of a flat target (e.g. a chessboard: `shapes` in the target's plane) whose
  // plane-to-camera pose is `target`, in the room, at the nominal light, with the same noise.
  void render_target(size_t camera, const CameraPose& target, const std::vector<FloorShape>& shapes, cv::Mat& bgr);

  // The illumination gain at time t (light_min .. light_max).
  double light_gain(double t) const;

  const std::vector<GroundCamera>& cameras() const { return cameras_; }

 private:
  struct View {
    GroundCamera camera;
    double valid_radius = 3.0;
    cv::Mat rays;        // CV_32FC2: normalised undistorted (x, y) of each pixel
    cv::Mat base;        // CV_32FC3: the room at unit gain, ramp and colour cast applied
    cv::Mat shading;     // CV_32FC3: ramp × colour cast per pixel and channel (for drawn objects)
    cv::Mat done;        // CV_8U work mask
  };
  struct Primitive;
  View make_view(const GroundCamera& camera);
  void add_noise(cv::Mat& image16);
  std::vector<Primitive> primitives(const View& view, const std::vector<MarkedVehicle>& vehicles) const;

  GroundCameraParams p_;
  std::vector<GroundCamera> cameras_;
  std::vector<View> views_;
  Rng rng_;
  std::array<double, 4> light_phase_{};
  std::vector<cv::Mat> noise_bank_;  // CV_16SC3, taller than the image
  std::vector<double> crossings_;
  cv::Mat coverage_;
};

}  // namespace quad::sim
