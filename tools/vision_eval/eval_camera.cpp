#include "eval_camera.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <opencv2/calib3d.hpp>

namespace vision_eval {

EvalRig fpv_rig() {
  EvalRig rig;
  rig.left.size = rig.right.size = cv::Size(720, 480);
  rig.left.K = cv::Matx33d(452.0, 0.0, 362.5, 0.0, 447.0, 236.0, 0.0, 0.0, 1.0);
  rig.left.D = cv::Vec<double, 5>(-0.32, 0.12, 0.0005, -0.0003, -0.02);
  rig.right.K = cv::Matx33d(446.0, 0.0, 355.0, 0.0, 442.5, 243.5, 0.0, 0.0, 1.0);
  rig.right.D = cv::Vec<double, 5>(-0.30, 0.10, -0.0004, 0.0006, -0.015);
  cv::Matx31d rvec(0.006, -0.011, 0.004);  // about 0.7° of mounting error
  cv::Rodrigues(rvec, rig.R);
  rig.T = cv::Vec3d(-0.1203, 0.0011, -0.0009);
  return rig;
}

CameraPose right_pose(const EvalRig& rig, const CameraPose& left) {
  // p_r = R p_l + T = R R_lp (p − C_l) + T  →  R_rp = R R_lp,  C_r = C_l − R_rpᵀ T.
  CameraPose right;
  right.R_cp = rig.R * left.R_cp;
  right.C = left.C - right.R_cp.t() * rig.T;
  return right;
}

std::vector<cv::Point2f> project(const EvalCamera& camera, const CameraPose& pose,
                                 const std::vector<cv::Point3d>& plane_points) {
  cv::Matx31d rvec;
  cv::Rodrigues(pose.R_cp, rvec);
  const cv::Vec3d tvec = -(pose.R_cp * pose.C);
  std::vector<cv::Point2d> pixels;
  cv::projectPoints(plane_points, rvec, tvec, camera.K, camera.D, pixels);
  return std::vector<cv::Point2f>(pixels.begin(), pixels.end());
}

RayGrid::RayGrid(const EvalCamera& camera, int factor) {
  const int w = camera.size.width * factor, h = camera.size.height * factor;
  std::vector<cv::Point2d> pixels;
  pixels.reserve(static_cast<size_t>(w) * h);
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      // Centre of a sub-pixel in full-resolution pixel coordinates (pixel centres at integers).
      pixels.emplace_back((c + 0.5) / factor - 0.5, (r + 0.5) / factor - 0.5);
    }
  }
  std::vector<cv::Point2d> rays;
  cv::undistortPoints(pixels, rays, camera.K, camera.D, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-14));
  // Independent check of the inversion: project a sample of the rays forward again.
  std::vector<cv::Point3d> sample;
  std::vector<size_t> index;
  for (size_t i = 0; i < rays.size(); i += 97) {
    sample.emplace_back(rays[i].x, rays[i].y, 1.0);
    index.push_back(i);
  }
  std::vector<cv::Point2d> back;
  cv::projectPoints(sample, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera.K, camera.D, back);
  for (size_t k = 0; k < back.size(); ++k) {
    const double e = cv::norm(back[k] - pixels[index[k]]);
    if (!(e < 0.01)) {
      throw std::runtime_error("lens inversion off by " + std::to_string(e) + " px at pixel (" +
                               std::to_string(pixels[index[k]].x) + ", " + std::to_string(pixels[index[k]].y) + ")");
    }
  }
  rays_x_.create(h, w, CV_32F);
  rays_y_.create(h, w, CV_32F);
  for (int r = 0; r < h; ++r) {
    for (int c = 0; c < w; ++c) {
      rays_x_.at<float>(r, c) = static_cast<float>(rays[static_cast<size_t>(r) * w + c].x);
      rays_y_.at<float>(r, c) = static_cast<float>(rays[static_cast<size_t>(r) * w + c].y);
    }
  }
}

void RayGrid::plane_hits(const CameraPose& pose, cv::Mat& x, cv::Mat& y) const {
  // Ray in plane coordinates d = R_cpᵀ (xn, yn, 1); hit where C + s d has z = 0.
  const cv::Matx33d Rt = pose.R_cp.t();
  x.create(rays_x_.size(), CV_32F);
  y.create(rays_x_.size(), CV_32F);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int r = 0; r < rays_x_.rows; ++r) {
    const float* rx = rays_x_.ptr<float>(r);
    const float* ry = rays_y_.ptr<float>(r);
    float* ox = x.ptr<float>(r);
    float* oy = y.ptr<float>(r);
    for (int c = 0; c < rays_x_.cols; ++c) {
      const double dx = Rt(0, 0) * rx[c] + Rt(0, 1) * ry[c] + Rt(0, 2);
      const double dy = Rt(1, 0) * rx[c] + Rt(1, 1) * ry[c] + Rt(1, 2);
      const double dz = Rt(2, 0) * rx[c] + Rt(2, 1) * ry[c] + Rt(2, 2);
      const double s = -pose.C[2] / dz;
      if (!(s > 0.0) || !std::isfinite(s)) {
        ox[c] = oy[c] = nan;
        continue;
      }
      ox[c] = static_cast<float>(pose.C[0] + s * dx);
      oy[c] = static_cast<float>(pose.C[1] + s * dy);
    }
  }
}

}  // namespace vision_eval
