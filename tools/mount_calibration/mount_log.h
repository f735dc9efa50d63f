// The camera mount from a flight log: the firmware's ULog pairs each vision fix's star attitude
// (vision_fix.q = q_VS: the star's axes in the body frame V the fix is given in, the station's nominal
// camera-to-body rotation and the firmware's EST_CAM_* applied) with the estimator's attitude at the
// fix's capture time (vehicle_attitude.q = q_NB, interpolated), and solves R_i = X Q_i Y (seed 002
// eq. 11) with R_i = R_NB, Q_i = R_SV = R_VSᵀ, X = R_NS (the star/floor frame in NED) and Y = R_VB
// (the mount error left in the log's fixes). The firmware's mount is R_BV = Yᵀ composed with the log's
// own EST_CAM_*.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "quad/estimation/xqy_calibration.h"

namespace quad::mount {

struct LogPairs {
  std::vector<est::RotationPair> pairs;
  int fixes_with_attitude = 0;     // vision_fix records with a finite, non-identity q
  int outside_attitude_span = 0;   // of those, captured where no vehicle_attitude brackets them
  Eigen::Vector3d logged_mount_rad = Eigen::Vector3d::Zero();  // EST_CAM_ROLL/PITCH/YAW the log ran with
  // EST_STAR_ATT the log ran with (-1: not in the log). Above 0 the estimator took the star's heading
  // (and at 2 its tilt): a mount error then turns the estimate with the fixes and hides from the pairs.
  float logged_star_attitude = -1.0f;
};

// Throws std::runtime_error naming the file when the log lacks a topic or field.
LogPairs read_log_pairs(const std::string& path);

// The station names the star's tip nearest the body's forward axis x (star_pose.h), so its star frame
// turns by 90° as the vehicle yaws: each Q_i is turned by k·90° about the star's z so that all samples
// share the first sample's star frame (X is one rotation).
void unify_star_frame(std::vector<est::RotationPair>* pairs);

struct MountResult {
  est::XqyResult xqy;
  Eigen::Matrix3d R_BV_residual = Eigen::Matrix3d::Identity();  // Yᵀ: what the log's fixes still carry
  Eigen::Matrix3d R_BV = Eigen::Matrix3d::Identity();           // with the log's EST_CAM_*: the parameters to set
  int samples = 0;
  int outliers = 0;
};

// Solves, drops the samples whose residual exceeds max(4 x RMS, 1°) and solves again.
MountResult calibrate_mount(const LogPairs& log, const est::XqyOptions& options);

// ZYX Euler angles (roll, pitch, yaw) of a rotation and back.
Eigen::Vector3d euler_zyx(const Eigen::Matrix3d& R);
Eigen::Matrix3d from_euler_zyx(const Eigen::Vector3d& roll_pitch_yaw);

}  // namespace quad::mount
