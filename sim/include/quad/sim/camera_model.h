// The simulator's own model of the vehicle's two downward cameras: the lens (pinhole with OpenCV's
// radial/tangential polynomial, forward direction), where each camera sits on the airframe (read from
// the MJCF's cam_left / cam_right) and the image size. It is written here, apart from the vision
// station's rig code on purpose: the station must learn these cameras from chessboard images alone
// (`vision_station calibrate`), so a mistake in its lens or rig model shows in every flight instead of
// being copied into the images it is tested on. tests/sim/test_camera_model.cpp checks the projection
// against cv::projectPoints.
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <mujoco/mujoco.h>

#include "quad/sim/scenario.h"

namespace quad::sim {

// One camera's projection of a point in its own frame (OpenCV axes: x right, y down, z along the view).
// Beyond 0.97 of the radius where the lens polynomial folds back (the image corners of a strongly
// distorting lens), the polynomial is continued linearly through the origin so the periphery stays in
// order; inside, it is OpenCV's model exactly. nullopt behind the camera.
std::optional<Eigen::Vector2d> project_lens(const LensParams& lens, double valid_radius, const Eigen::Vector3d& p);

// The undistorted normalised radius at which r·(1 + k1 r² + k2 r⁴ + k3 r⁶) stops growing (3 when it
// never does within r < 3).
double lens_fold_radius(const LensParams& lens);

// Inverse of the lens: the normalised undistorted (x, y) whose projection is the pixel (u, v), by
// Newton's method on the forward model (the linear continuation beyond the fold); nullopt when it does
// not converge.
std::optional<Eigen::Vector2d> unproject_lens(const LensParams& lens, double valid_radius, const Eigen::Vector2d& uv);

// A camera on the airframe: p_B = R_BC p_C + t_BC (body FRD; thesis eq. 7.22 form).
struct CameraMountModel {
  Eigen::Matrix3d R_BC = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t_BC = Eigen::Vector3d::Zero();
};

// The two cameras as the simulator renders them.
struct SimStereoRig {
  int width = 728, height = 488;
  LensParams left, right;
  CameraMountModel left_mount, right_mount;

  // x_right = R_right_left · x_left + T_right_left (camera frames, metres): what a stereo calibration
  // should find.
  Eigen::Matrix3d R_right_left() const { return right_mount.R_BC.transpose() * left_mount.R_BC; }
  Eigen::Vector3d T_right_left() const { return right_mount.R_BC.transpose() * (left_mount.t_BC - right_mount.t_BC); }
  double baseline_m() const { return (right_mount.t_BC - left_mount.t_BC).norm(); }
};

// Reads the cameras' mounts from the model's cam_left / cam_right (MuJoCo cameras look along −z with
// y up; the body is FLU) and takes lenses and image size from the scenario's camera keys. Throws
// std::runtime_error naming the model when a camera is missing.
SimStereoRig stereo_rig_from_model(const mjModel* model, const CameraParams& params, const std::string& model_path);

// The rig turned by a mount error about the body origin (CameraParams::mount_error_rad): R_BC = E R_BC,
// t_BC = E t_BC for both cameras, E = Rz(yaw) Ry(pitch) Rx(roll); the cameras' relative pose is kept.
SimStereoRig misaligned(const SimStereoRig& rig, const Eigen::Vector3d& mount_error_rad);

// The vehicle-independent half of a view: p_camera = R · p_plane + t for points of a plane (the floor in
// NED north/east with down = 0, or a chessboard in its own x/y).
struct CameraPose {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
};

// A camera's pose over the floor from the vehicle's NED position and attitude through its mount.
CameraPose camera_pose_over_floor(const CameraMountModel& mount, const Eigen::Vector3d& p_ned,
                                  const Eigen::Quaterniond& q_ib);

}  // namespace quad::sim
