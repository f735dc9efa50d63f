#include "quad/vision/ground/marker_geometry.h"

#include "quad/vision/star_pose.h"  // quaternion_from_rotation

#include <cmath>

namespace quad::vision::ground {
namespace {

cv::Matx33d skew(const cv::Vec3d& v) { return cv::Matx33d(0, -v[2], v[1], v[2], 0, -v[0], -v[1], v[0], 0); }

// Reprojection residuals (2 per view) and their Jacobian with respect to the point.
void residuals(const std::vector<PixelObservation>& views, const cv::Vec3d& X, cv::Mat& r, cv::Mat& J, bool& in_front) {
  const int m = static_cast<int>(views.size());
  r.create(2 * m, 1, CV_64F);
  J.create(2 * m, 3, CV_64F);
  in_front = true;
  for (int k = 0; k < m; ++k) {
    const cv::Matx34d& P = views[k].P;
    const cv::Vec4d Xh(X[0], X[1], X[2], 1.0);
    const cv::Vec3d x = P * Xh;  // seed 003 eq. 3.1
    if (x[2] <= 1e-9) in_front = false;
    const double w = x[2];
    const double u = x[0] / w, v = x[1] / w;
    r.at<double>(2 * k) = u - views[k].pixel.x;
    r.at<double>(2 * k + 1) = v - views[k].pixel.y;
    for (int c = 0; c < 3; ++c) {
      J.at<double>(2 * k, c) = (P(0, c) - u * P(2, c)) / w;
      J.at<double>(2 * k + 1, c) = (P(1, c) - v * P(2, c)) / w;
    }
  }
}

}  // namespace

std::optional<TriangulatedPoint> triangulate(const std::vector<PixelObservation>& views, double sigma_px) {
  if (views.size() < 2) return std::nullopt;
  // DLT: each view gives u·P3 − P1 = 0 and v·P3 − P2 = 0 (Hartley & Zisserman 12.2, seed 003 ref. [6]).
  cv::Mat A(2 * static_cast<int>(views.size()), 4, CV_64F);
  for (size_t k = 0; k < views.size(); ++k) {
    const cv::Matx34d& P = views[k].P;
    for (int c = 0; c < 4; ++c) {
      A.at<double>(2 * k, c) = views[k].pixel.x * P(2, c) - P(0, c);
      A.at<double>(2 * k + 1, c) = views[k].pixel.y * P(2, c) - P(1, c);
    }
  }
  cv::Mat w, u, vt;
  cv::SVD::compute(A, w, u, vt, cv::SVD::FULL_UV);
  const double h = vt.at<double>(3, 3);
  if (std::abs(h) < 1e-12) return std::nullopt;
  cv::Vec3d X(vt.at<double>(3, 0) / h, vt.at<double>(3, 1) / h, vt.at<double>(3, 2) / h);
  cv::Mat r, J;
  bool in_front = true;
  for (int iteration = 0; iteration < 5; ++iteration) {
    residuals(views, X, r, J, in_front);
    cv::Mat step;
    if (!cv::solve(J, -r, step, cv::DECOMP_SVD)) break;
    X += cv::Vec3d(step.at<double>(0), step.at<double>(1), step.at<double>(2));
    if (cv::norm(step) < 1e-9) break;
  }
  residuals(views, X, r, J, in_front);
  if (!in_front) return std::nullopt;
  TriangulatedPoint point;
  point.ned = X;
  const cv::Mat info = J.t() * J;
  point.covariance = cv::Matx33d(cv::Mat(info.inv(cv::DECOMP_SVD) * (sigma_px * sigma_px)));
  point.reprojection_rms_px = cv::norm(r) / std::sqrt(static_cast<double>(r.rows));
  return point;
}

std::optional<RigidPose> fit_rigid_pose(const std::vector<cv::Vec3d>& body, const std::vector<TriangulatedPoint>& ned) {
  const size_t n = body.size();
  if (n < 3 || ned.size() != n) return std::nullopt;
  cv::Vec3d cb, cn;
  for (size_t i = 0; i < n; ++i) {
    cb += body[i];
    cn += ned[i].ned;
  }
  cb *= 1.0 / n;
  cn *= 1.0 / n;
  cv::Matx33d H = cv::Matx33d::zeros();  // Kabsch: cross-covariance of the centred sets
  for (size_t i = 0; i < n; ++i) H += (ned[i].ned - cn) * (body[i] - cb).t();
  cv::Mat w, u, vt;
  cv::SVD::compute(cv::Mat(H), w, u, vt);
  if (w.at<double>(1) < 1e-9 * std::max(w.at<double>(0), 1e-12)) return std::nullopt;  // collinear markers
  const cv::Matx33d U(u), Vt(vt);
  const double d = cv::determinant(U * Vt) < 0 ? -1.0 : 1.0;
  RigidPose pose;
  pose.R_IB = U * cv::Matx33d::diag(cv::Vec3d(1, 1, d)) * Vt;
  pose.position_ned = cn - pose.R_IB * cb;
  pose.q_IB = quaternion_from_rotation(pose.R_IB);

  // Information of the six parameters (position, small rotation about NED axes):
  // p_i ≈ position + R·b_i − [R·b_i]x·δθ.
  cv::Matx<double, 6, 6> info = cv::Matx<double, 6, 6>::zeros();
  double sum_sq = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const cv::Vec3d rb = pose.R_IB * body[i];
    const cv::Vec3d e = ned[i].ned - (pose.position_ned + rb);
    sum_sq += e.dot(e);
    cv::Matx<double, 3, 6> J;
    const cv::Matx33d s = -skew(rb);
    for (int r = 0; r < 3; ++r) {
      J(r, r) = 1.0;
      for (int c = 0; c < 3; ++c) J(r, 3 + c) = s(r, c);
    }
    info += J.t() * ned[i].covariance.inv(cv::DECOMP_SVD) * J;
  }
  const cv::Matx<double, 6, 6> cov = info.inv(cv::DECOMP_SVD);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      pose.position_covariance(r, c) = cov(r, c);
      pose.attitude_covariance(r, c) = cov(3 + r, 3 + c);
    }
  }
  pose.fit_rms_m = std::sqrt(sum_sq / n);
  return pose;
}

}  // namespace quad::vision::ground
