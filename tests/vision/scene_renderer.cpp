#include "scene_renderer.h"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace quad::vision::testing {
namespace {

constexpr double kValidFraction = 0.97;
constexpr int kSamplesPerEdge = 24;

std::vector<cv::Point2d> densify(const std::vector<cv::Point2d>& outline) {
  std::vector<cv::Point2d> dense;
  dense.reserve(outline.size() * kSamplesPerEdge);
  for (size_t i = 0; i < outline.size(); ++i) {
    const cv::Point2d a = outline[i];
    const cv::Point2d b = outline[(i + 1) % outline.size()];
    for (int k = 0; k < kSamplesPerEdge; ++k) dense.push_back(a + (b - a) * (static_cast<double>(k) / kSamplesPerEdge));
  }
  return dense;
}

}  // namespace

double max_valid_radius(const CameraIntrinsics& camera) {
  const double k1 = camera.D[0], k2 = camera.D[1], k3 = camera.D[4];
  for (double r = 0.0; r < 3.0; r += 1e-4) {
    const double r2 = r * r;
    if (1.0 + 3.0 * k1 * r2 + 5.0 * k2 * r2 * r2 + 7.0 * k3 * r2 * r2 * r2 <= 0.0) return r;
  }
  return 3.0;
}

std::optional<cv::Point2d> project(const CameraIntrinsics& camera, const Pose& pose, const cv::Point2d& q) {
  const cv::Vec3d p = pose.R * cv::Vec3d(q.x, q.y, 0.0) + pose.t;
  if (p[2] <= 1e-6) return std::nullopt;
  const double x = p[0] / p[2], y = p[1] / p[2];
  const double r2 = x * x + y * y;
  if (std::sqrt(r2) > kValidFraction * max_valid_radius(camera)) return std::nullopt;
  const cv::Vec<double, 5>& D = camera.D;
  const double radial = 1.0 + D[0] * r2 + D[1] * r2 * r2 + D[4] * r2 * r2 * r2;
  const double xd = x * radial + 2.0 * D[2] * x * y + D[3] * (r2 + 2.0 * x * x);
  const double yd = y * radial + D[2] * (r2 + 2.0 * y * y) + 2.0 * D[3] * x * y;
  const cv::Matx33d& K = camera.K;
  return cv::Point2d(K(0, 0) * xd + K(0, 1) * yd + K(0, 2), K(1, 1) * yd + K(1, 2));
}

bool fully_visible(const CameraIntrinsics& camera, cv::Size size, const Pose& pose,
                   const std::vector<cv::Point2d>& outline, double margin_px) {
  for (const cv::Point2d& q : densify(outline)) {
    const std::optional<cv::Point2d> p = project(camera, pose, q);
    if (!p || p->x < margin_px || p->y < margin_px || p->x > size.width - 1 - margin_px ||
        p->y > size.height - 1 - margin_px) {
      return false;
    }
  }
  return true;
}

namespace {

// Anti-aliased coverage (0..1, CV_32F, in `out`) of a floor polygon over its bounding box in the image;
// returns that box (empty when the polygon is off the image) or nullopt when it cannot be projected.
std::optional<cv::Rect> coverage(const CameraIntrinsics& camera, cv::Size size, const Pose& pose,
                                 const std::vector<cv::Point2d>& outline, int ss, cv::Mat& out) {
  std::vector<cv::Point2d> image_points;
  for (const cv::Point2d& q : densify(outline)) {
    const std::optional<cv::Point2d> p = project(camera, pose, q);
    if (!p) return std::nullopt;
    image_points.push_back(*p);
  }
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const cv::Point2d& p : image_points) {
    x0 = std::min(x0, p.x); y0 = std::min(y0, p.y); x1 = std::max(x1, p.x); y1 = std::max(y1, p.y);
  }
  const cv::Rect box = cv::Rect(cv::Point(static_cast<int>(std::floor(x0)) - 1, static_cast<int>(std::floor(y0)) - 1),
                                cv::Point(static_cast<int>(std::ceil(x1)) + 2, static_cast<int>(std::ceil(y1)) + 2)) &
                       cv::Rect(0, 0, size.width, size.height);
  if (box.empty()) return box;
  // Pixel i covers [i − ½, i + ½]; sub-pixel k of the canvas has its centre at (k + ½)/ss − ½.
  constexpr int kShift = 8;
  std::vector<cv::Point> canvas_points;
  for (const cv::Point2d& p : image_points) {
    const double cx = ((p.x - box.x) + 0.5) * ss - 0.5;
    const double cy = ((p.y - box.y) + 0.5) * ss - 0.5;
    canvas_points.emplace_back(cvRound(cx * (1 << kShift)), cvRound(cy * (1 << kShift)));
  }
  cv::Mat canvas = cv::Mat::zeros(box.height * ss, box.width * ss, CV_8UC1);
  const cv::Point* pts = canvas_points.data();
  const int n = static_cast<int>(canvas_points.size());
  cv::fillPoly(canvas, &pts, &n, 1, cv::Scalar(255), cv::LINE_8, kShift);
  cv::Mat small;
  cv::resize(canvas, small, box.size(), 0, 0, cv::INTER_AREA);
  small.convertTo(out, CV_32F, 1.0 / 255.0);
  return box;
}

}  // namespace

std::optional<cv::Mat> render_view(const CameraIntrinsics& camera, cv::Size size, const Pose& pose,
                                   const std::vector<FloorShape>& shapes, const RenderOptions& options, cv::RNG& rng) {
  cv::Mat albedo(size, CV_32F, cv::Scalar(options.floor_grey));
  cv::Mat alpha;
  for (const FloorShape& shape : shapes) {
    const std::optional<cv::Rect> box = coverage(camera, size, pose, shape.outline, options.supersample, alpha);
    if (!box) return std::nullopt;
    if (box->empty()) continue;
    cv::Mat region = albedo(*box);
    region = region.mul(1.0 - alpha) + alpha * shape.grey;
  }
  // Lighting: a linear gradient across the image and soft shadows.
  cv::Mat light(size, CV_32F);
  const double gx = std::cos(options.gradient_angle), gy = std::sin(options.gradient_angle);
  const double span = std::fabs(gx) * size.width + std::fabs(gy) * size.height;
  const double offset = std::min(0.0, gx * size.width) + std::min(0.0, gy * size.height);
  for (int v = 0; v < size.height; ++v) {
    float* row = light.ptr<float>(v);
    for (int u = 0; u < size.width; ++u) {
      row[u] = static_cast<float>(1.0 - options.gradient * ((gx * u + gy * v - offset) / span));
    }
  }
  for (const FloorShadow& shadow : options.shadows) {
    const std::optional<cv::Rect> box = coverage(camera, size, pose, shadow.outline, options.supersample, alpha);
    if (!box) return std::nullopt;
    if (box->empty()) continue;
    cv::Mat shade(size, CV_32F, cv::Scalar(0.0));
    alpha.copyTo(shade(*box));
    cv::GaussianBlur(shade, shade, cv::Size(), options.shadow_blur_px);
    light = light.mul(1.0 - shade * (1.0 - shadow.factor));
  }
  cv::Mat image = albedo.mul(light);
  if (options.blur_sigma_px > 0.0) cv::GaussianBlur(image, image, cv::Size(), options.blur_sigma_px);
  cv::Mat noise(size, CV_32F);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noise_sigma);
  image += noise;
  cv::Mat out;
  image.convertTo(out, CV_8U);  // saturating
  if (options.salt_pepper_fraction > 0.0) {
    const int count = static_cast<int>(options.salt_pepper_fraction * size.area());
    for (int i = 0; i < count; ++i) {
      out.at<uint8_t>(rng.uniform(0, size.height), rng.uniform(0, size.width)) = (i % 2 == 0) ? 255 : 0;
    }
  }
  return out;
}

Pose right_pose(const StereoRig& rig, const Pose& left) {
  return Pose{rig.R * left.R, rig.R * left.t + rig.T};
}

std::vector<cv::Point2d> regular_polygon(cv::Point2d centre, double radius, int sides, double rotation) {
  std::vector<cv::Point2d> v;
  for (int i = 0; i < sides; ++i) {
    const double a = rotation + 2.0 * CV_PI * i / sides;
    v.emplace_back(centre.x + radius * std::cos(a), centre.y + radius * std::sin(a));
  }
  return v;
}

Pose camera_pose(double height, double tilt, double tilt_azimuth, double yaw, cv::Point2d ray, cv::Point2d target) {
  // Untilted: floor x along image x, floor y along image −y, floor normal (up) along −z (camera looks down).
  const cv::Matx33d flip(1, 0, 0, 0, -1, 0, 0, 0, -1);
  const cv::Matx33d Rz(std::cos(yaw), -std::sin(yaw), 0, std::sin(yaw), std::cos(yaw), 0, 0, 0, 1);
  cv::Matx33d Rt;
  cv::Rodrigues(cv::Vec3d(std::cos(tilt_azimuth), std::sin(tilt_azimuth), 0.0) * tilt, Rt);
  const cv::Matx33d R = Rt * flip * Rz;
  // The floor plane n·p = −height with n = R e_z (its upward normal, in camera coordinates).
  const cv::Vec3d n = R * cv::Vec3d(0, 0, 1);
  const cv::Vec3d r(ray.x, ray.y, 1.0);
  const double s = -height / n.dot(r);
  const cv::Vec3d hit = s * r;
  // hit is where floor point `target` must land: t = hit − R·target.
  return Pose{R, hit - R * cv::Vec3d(target.x, target.y, 0.0)};
}

}  // namespace quad::vision::testing
