#include "quad/vision/thesis_rig.h"

namespace quad::vision {
namespace {

// fx = s·f, fy = f (eq. 7.26a scales only X); principal point (c_x, c_y).
CameraIntrinsics thesis_camera(double f, double s, double cx, double cy, double k1, double k2, double k3) {
  CameraIntrinsics camera;
  camera.K = cv::Matx33d(s * f, 0.0, cx, 0.0, f, cy, 0.0, 0.0, 1.0);
  camera.D = cv::Vec<double, 5>(k1, k2, 0.0, 0.0, k3);
  return camera;
}

// Nearest rotation to a rounded printed matrix (the eq. 7.34 entries have 2–4 digits).
cv::Matx33d nearest_rotation(const cv::Matx33d& m) {
  cv::SVD svd(cv::Mat(m), cv::SVD::FULL_UV);
  cv::Mat r = svd.u * svd.vt;
  if (cv::determinant(r) < 0) {
    cv::Mat u = svd.u.clone();
    u.col(2) *= -1.0;
    r = u * svd.vt;
  }
  return cv::Matx33d(r);
}

}  // namespace

StereoRig thesis_stereo_rig() {
  StereoRig rig;
  rig.image_size = cv::Size(728, 488);
  // Table 7.1.
  rig.left = thesis_camera(456.4, 1.059, 331.4, 211.4, -0.5176, 0.3257, -0.1186);
  rig.right = thesis_camera(461.5, 1.059, 341.6, 244.4, -0.4976, 0.2730, -0.0791);
  // Eq. 7.34: the rectifying rotations of the left and right cameras.
  const cv::Matx33d R_l = nearest_rotation(
      cv::Matx33d(0.998, -0.002, 0.07, 0.003, 0.9999, -0.011, -0.07, 0.011, 0.997));
  const cv::Matx33d R_r = nearest_rotation(
      cv::Matx33d(0.997, 0.061, 0.050, -0.061, 0.998, 0.011, -0.049, -0.014, 0.999));
  rig.R = R_r.t() * R_l;
  // The right camera's centre lies on the rectified x axis of the left camera, kThesisBaseline away;
  // x_right = R (x_left − c_right) gives T = −R c_right.
  const cv::Vec3d c_right = R_l.t() * cv::Vec3d(kThesisBaseline, 0.0, 0.0);
  rig.T = -(rig.R * c_right);
  return rig;
}

CameraMount thesis_camera_mount() {
  // Thesis eq. 7.22.
  return CameraMount{cv::Matx33d(0, -1, 0, 1, 0, 0, 0, 0, 1), cv::Vec3d(0.057, -0.057, 0.055)};
}

}  // namespace quad::vision
