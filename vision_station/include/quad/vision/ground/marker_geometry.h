// From associated marker pixels to room points and vehicle poses: linear triangulation from the room
// cameras' projection matrices (seed 003 eq. 3.1, the "linear triangulation method" of its sec. 6.2) with
// the covariance that pixel noise gives, and the vehicle's pose as the rigid fit of its body marker
// layout to the triangulated markers (seed 003 eq. 4.4 solved for position and attitude).
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

namespace quad::vision::ground {

// One observation: a camera's projection matrix and the undistorted pixel.
struct PixelObservation {
  cv::Matx34d P;
  cv::Point2d pixel;
};

struct TriangulatedPoint {
  cv::Vec3d ned;
  cv::Matx33d covariance;     // m², from isotropic pixel noise sigma_px through the reprojection Jacobian
  double reprojection_rms_px = 0.0;
};

// DLT over two or more views, then Gauss-Newton on the reprojection error. nullopt with fewer than two
// views or a point behind a camera.
std::optional<TriangulatedPoint> triangulate(const std::vector<PixelObservation>& views, double sigma_px);

struct RigidPose {
  cv::Vec3d position_ned;                  // body origin
  cv::Matx33d R_IB;                        // body FRD -> NED
  cv::Vec4d q_IB;                          // Hamilton, scalar first
  cv::Matx33d position_covariance;         // m²
  cv::Matx33d attitude_covariance;         // rad², small rotation about NED axes
  double fit_rms_m = 0.0;
};

// Kabsch/Umeyama (no scale): p_i = position + R_IB·body_i, at least three non-collinear markers; the
// covariance from each marker's covariance (Gauss-Newton information of the fit).
std::optional<RigidPose> fit_rigid_pose(const std::vector<cv::Vec3d>& body_frd, const std::vector<TriangulatedPoint>& ned);

}  // namespace quad::vision::ground
