// Two fixed, unknown rotations X and Y from paired rotation measurements R_i = X Q_i Y (seed 002 eq. 11,
// "Solution of R = XQY"): X from the relative rotations R_i R_jᵀ = X Q_i Q_jᵀ Xᵀ (eq. 12-16), Y from
// R_jᵀ R_i = Yᵀ Q_jᵀ Q_i Y (eq. 17), each a Wahba problem solved by the SVD. Host only (Eigen, C++17):
// library quad_estimation_host.
//
// The camera mount: R_i = R_NB (the IMU body's attitude in NED, from the onboard estimator), Q_i = R_SV
// (V: the body frame as the camera rig and the station take it, the station's R_BC applied; Q_i is the
// transpose of the star attitude q_VS the fix carries), X = R_NS (the star on the floor in NED: the
// floor/star-to-NED rotation), Y = R_VB (the IMU body in the rig's body frame: the mount error). The
// firmware applies Yᵀ = R_BV to every fix (EST_CAM_ROLL/PITCH/YAW, quad/firmware/vision.h CameraMount).
//
// With XqyOptions::star_heading_known, X's heading is the star layout's (a departure from the seed,
// explained there).
//
// Usage:
//   std::vector<quad::est::RotationPair> pairs = ...;   // at least 3, rotated about two axes or more
//   quad::est::XqyResult r = quad::est::solve_xqy(pairs, {});
//   if (!r.ok) std::cerr << r.message; else use r.X, r.Y
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace quad {
namespace est {

struct RotationPair {
  Eigen::Matrix3d R;  // seed 002 eq. 11: R_i = X Q_i Y
  Eigen::Matrix3d Q;
};

struct XqyOptions {
  // Pairs (i, j) whose relative rotation is smaller than this carry mostly noise in their axis: left out.
  double min_relative_angle_rad = 0.02;
  // Relative rotations beyond this are left out (the logarithm's axis is ill-defined near pi).
  double max_relative_angle_rad = 3.0;
  // At most this many samples (evenly spaced) enter the O(N^2) sums.
  int max_samples = 400;
  // Rotations about a single axis leave X (and Y) free about it (seed errata: N >= 3 samples about
  // non-parallel axes): the second singular value of Z relative to the first must reach this. A
  // calibration flight's yaw turns (up to 180°) outweigh its tilts (10°) by about 1000 in Z.
  double min_axis_spread = 2e-4;
  // A departure from seed 002, which leaves X free: when the star's layout on the floor is known (the
  // product's: its tips along north and east, as VIS_STAR_* and the EKF's heading update assume), X's
  // heading (its ZYX yaw) is that layout's, star_heading_rad modulo a quarter turn (the station's star
  // frame is one of four), and only X's tilt (the floor's) comes from eq. 15-16. Y is then the rotation
  // nearest sum (X Q_i)ᵀ R_i (least squares for that X). Why: X's yaw and Y's yaw trade against each
  // other unless the flight rotates well about two horizontal axes; with the heading known, yaw turns
  // alone fix Y, and the rotations need not span two axes.
  bool star_heading_known = false;
  double star_heading_rad = 0.0;
};

struct XqyResult {
  bool ok = false;
  std::string message;                     // why not ok
  Eigen::Matrix3d X = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d Y = Eigen::Matrix3d::Identity();
  int samples = 0;                         // samples that entered the sums
  long relative_pairs_x = 0;               // (i, j) pairs in eq. 15 for X
  long relative_pairs_y = 0;               // and for Y (eq. 17)
  Eigen::Vector3d singular_values_x = Eigen::Vector3d::Zero();  // of Z (eq. 15), descending
  Eigen::Vector3d singular_values_y = Eigen::Vector3d::Zero();
  double residual_rms_rad = 0.0;           // angle of R_i (X Q_i Y)ᵀ over the samples, RMS
};

XqyResult solve_xqy(const std::vector<RotationPair>& pairs, const XqyOptions& options);

// The rotation Y minimising sum ||R_i - X Q_i Y||² for a given X: U diag(1, 1, det U Vᵀ) Vᵀ from the SVD
// of sum (X Q_i)ᵀ R_i.
Eigen::Matrix3d solve_y_given_x(const std::vector<RotationPair>& pairs, const Eigen::Matrix3d& X);

// The rotation vector r with exp(r^) = R (seed 002 eq. 13), angle in [0, pi].
Eigen::Vector3d rotation_log(const Eigen::Matrix3d& R);
// The rotation angle of R, radians.
double rotation_angle(const Eigen::Matrix3d& R);

}  // namespace est
}  // namespace quad
