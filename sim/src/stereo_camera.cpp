#include "quad/sim/stereo_camera.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "quad/vision/ideal_star.h"

namespace quad::sim {
namespace vis = quad::vision;

namespace {

constexpr int kSupersample = 4;       // sub-pixels per pixel side for the edge coverage
constexpr int kSegmentsPerEdge = 24;  // straight floor edges are curves in the distorted image
constexpr double kValidFraction = 0.97;
constexpr size_t kNoiseTable = size_t{1} << 21;

std::vector<Eigen::Vector2d> regular_polygon(const Eigen::Vector2d& centre, double radius, int sides, double rotation) {
  std::vector<Eigen::Vector2d> v;
  for (int i = 0; i < sides; ++i) {
    const double a = rotation + 2.0 * M_PI * i / sides;
    v.emplace_back(centre + radius * Eigen::Vector2d(std::cos(a), std::sin(a)));
  }
  return v;
}

Eigen::Matrix3d to_eigen(const cv::Matx33d& m) {
  Eigen::Matrix3d e;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) e(r, c) = m(r, c);
  return e;
}

// Vignetting: brightness falls off with the square of the distance from the principal point.
cv::Mat lighting_map(const vis::CameraIntrinsics& camera, cv::Size size, double vignetting) {
  cv::Mat light(size, CV_32F);
  const double cx = camera.K(0, 2), cy = camera.K(1, 2);
  const double corner2 = std::max({cx * cx + cy * cy, (size.width - cx) * (size.width - cx) + cy * cy,
                                   cx * cx + (size.height - cy) * (size.height - cy),
                                   (size.width - cx) * (size.width - cx) + (size.height - cy) * (size.height - cy)});
  for (int v = 0; v < size.height; ++v) {
    float* row = light.ptr<float>(v);
    for (int u = 0; u < size.width; ++u) {
      const double r2 = ((u - cx) * (u - cx) + (v - cy) * (v - cy)) / corner2;
      row[u] = static_cast<float>(1.0 - vignetting * r2);
    }
  }
  return light;
}

}  // namespace

std::vector<FloorShape> make_floor_scene(const CameraParams& params, Rng rng) {
  std::vector<FloorShape> scene;
  FloorShape star;
  for (const cv::Point2d& p : vis::star_vertices(vis::StarShape{0.5 * params.star_tip_to_tip_m, 0.4}))
    star.outline.emplace_back(p.x, p.y);
  star.grey = params.star_grey;
  scene.push_back(star);
  struct Placed {
    Eigen::Vector2d centre;
    double radius;
  };
  std::vector<Placed> placed{{Eigen::Vector2d::Zero(), 0.5 * params.star_tip_to_tip_m}};
  for (int attempt = 0; attempt < 500 && static_cast<int>(scene.size()) <= params.distractors; ++attempt) {
    const double radius = rng.uniform(0.05, 0.15);
    const double distance = rng.uniform(0.5, 2.5), bearing = rng.uniform(0.0, 2.0 * M_PI);
    const Eigen::Vector2d centre = distance * Eigen::Vector2d(std::cos(bearing), std::sin(bearing));
    // Apart by 10 cm at least: touching shapes would merge into new shapes.
    const bool clear = std::all_of(placed.begin(), placed.end(), [&](const Placed& o) {
      return (o.centre - centre).norm() > o.radius + radius + 0.10;
    });
    if (!clear) continue;
    const int kind = static_cast<int>(rng.uniform(0.0, 3.0));
    FloorShape shape;
    shape.outline = regular_polygon(centre, radius, kind == 0 ? 4 : kind == 1 ? 32 : 3, rng.uniform(0.0, M_PI));
    shape.grey = rng.uniform(25.0, 90.0);
    scene.push_back(shape);
    placed.push_back({centre, radius});
  }
  return scene;
}

CameraPose left_camera_pose(const vis::CameraMount& mount, const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib) {
  // p_B = R_IBᵀ (p_I − p), p_C = R_BCᵀ (p_B − t_BC)  (eq. 7.22 inverted).
  const Eigen::Matrix3d R_CB = to_eigen(mount.R_BC).transpose();
  const Eigen::Matrix3d R_BI = q_ib.toRotationMatrix().transpose();
  const Eigen::Vector3d t_BC(mount.t_BC[0], mount.t_BC[1], mount.t_BC[2]);
  return CameraPose{R_CB * R_BI, -R_CB * (R_BI * p_ned + t_BC)};
}

CameraPose right_camera_pose(const vis::StereoRig& rig, const CameraPose& left) {
  const Eigen::Matrix3d R = to_eigen(rig.R);
  const Eigen::Vector3d T(rig.T[0], rig.T[1], rig.T[2]);
  return CameraPose{R * left.R, R * left.t + T};
}

double fold_radius(const vis::CameraIntrinsics& camera) {
  const double k1 = camera.D[0], k2 = camera.D[1], k3 = camera.D[4];
  for (double r = 0.0; r < 3.0; r += 1e-4) {
    const double r2 = r * r;
    if (1.0 + 3.0 * k1 * r2 + 5.0 * k2 * r2 * r2 + 7.0 * k3 * r2 * r2 * r2 <= 0.0) return r;
  }
  return 3.0;
}

std::optional<cv::Point2d> project_point(const vis::CameraIntrinsics& camera, double valid_radius,
                                         const Eigen::Vector3d& p) {
  if (p.z() <= 1e-4) return std::nullopt;
  double x = p.x() / p.z(), y = p.y() / p.z();
  const double r = std::hypot(x, y), limit = kValidFraction * valid_radius;
  if (r > limit) {
    x *= limit / r;
    y *= limit / r;
  }
  // OpenCV's forward model (docs/vision_station.md, "Camera model"): the station inverts exactly this.
  const cv::Vec<double, 5>& D = camera.D;
  const double r2 = x * x + y * y;
  const double radial = 1.0 + D[0] * r2 + D[1] * r2 * r2 + D[4] * r2 * r2 * r2;
  const double xd = x * radial + 2.0 * D[2] * x * y + D[3] * (r2 + 2.0 * x * x);
  const double yd = y * radial + D[2] * (r2 + 2.0 * y * y) + 2.0 * D[3] * x * y;
  const cv::Matx33d& K = camera.K;
  return cv::Point2d(K(0, 0) * xd + K(0, 1) * yd + K(0, 2), K(1, 1) * yd + K(1, 2));
}

StereoCameraRenderer::StereoCameraRenderer(const CameraParams& params, std::vector<FloorShape> scene, Rng rng)
    : p_(params), scene_(std::move(scene)), scene_shapes_(scene_.size()), rng_(std::move(rng)), rig_(vis::thesis_stereo_rig()),
      mount_(vis::thesis_camera_mount()), valid_left_(fold_radius(rig_.left)), valid_right_(fold_radius(rig_.right)) {
  lighting_left_ = lighting_map(rig_.left, rig_.image_size, p_.vignetting);
  lighting_right_ = lighting_map(rig_.right, rig_.image_size, p_.vignetting);
  noise_.resize(kNoiseTable);
  for (int8_t& n : noise_) n = static_cast<int8_t>(std::clamp(std::lround(rng_.normal(p_.noise_grey)), -127L, 127L));
}

void StereoCameraRenderer::set_decoy(const std::optional<Eigen::Vector2d>& north_east) {
  scene_.resize(scene_shapes_);
  if (!north_east || scene_.empty()) return;
  FloorShape decoy = scene_.front();
  for (Eigen::Vector2d& v : decoy.outline) v += *north_east;
  scene_.push_back(std::move(decoy));
}

void StereoCameraRenderer::render(const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool hide_star,
                                  cv::Mat& left, cv::Mat& right) {
  // Exposure wanders slowly (auto-exposure hunting, clouds): an AR(1) walk of unit variance.
  exposure_walk_ = 0.9 * exposure_walk_ + std::sqrt(1.0 - 0.81) * rng_.normal();
  const double exposure = std::clamp(1.0 + p_.exposure_variation * exposure_walk_, 0.5, 1.5);
  const CameraPose pose_left = left_camera_pose(mount_, p_ned, q_ib);
  render_view(rig_.left, valid_left_, pose_left, hide_star, exposure, lighting_left_, left);
  render_view(rig_.right, valid_right_, right_camera_pose(rig_, pose_left), hide_star, exposure, lighting_right_, right);
}

void StereoCameraRenderer::render_view(const vis::CameraIntrinsics& camera, double valid_radius, const CameraPose& pose,
                                       bool hide_star, double exposure, const cv::Mat& lighting, cv::Mat& out) {
  const cv::Size size = rig_.image_size;
  albedo_.create(size, CV_32F);
  albedo_.setTo(cv::Scalar(p_.floor_grey));
  const cv::Rect image_rect(0, 0, size.width, size.height);
  std::vector<cv::Point2d> projected;
  std::vector<cv::Point> canvas_points;
  for (size_t s = hide_star ? 1 : 0; s < scene_.size(); ++s) {
    const FloorShape& shape = scene_[s];
    projected.clear();
    bool visible = true;
    for (size_t i = 0; i < shape.outline.size() && visible; ++i) {
      const Eigen::Vector2d a = shape.outline[i], b = shape.outline[(i + 1) % shape.outline.size()];
      for (int k = 0; k < kSegmentsPerEdge; ++k) {
        const Eigen::Vector2d q = a + (b - a) * (static_cast<double>(k) / kSegmentsPerEdge);
        const std::optional<cv::Point2d> uv = project_point(camera, valid_radius, pose.R * Eigen::Vector3d(q.x(), q.y(), 0.0) + pose.t);
        if (!uv) {
          visible = false;
          break;
        }
        projected.push_back(*uv);
      }
    }
    if (!visible) continue;
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (const cv::Point2d& uv : projected) {
      x0 = std::min(x0, uv.x); y0 = std::min(y0, uv.y); x1 = std::max(x1, uv.x); y1 = std::max(y1, uv.y);
    }
    if (x1 < -1.0 || y1 < -1.0 || x0 > size.width || y0 > size.height) continue;
    const cv::Rect box = cv::Rect(cv::Point(static_cast<int>(std::floor(std::max(x0, -1.0))) - 1,
                                            static_cast<int>(std::floor(std::max(y0, -1.0))) - 1),
                                  cv::Point(static_cast<int>(std::ceil(std::min(x1, size.width + 1.0))) + 2,
                                            static_cast<int>(std::ceil(std::min(y1, size.height + 1.0))) + 2)) &
                         image_rect;
    if (box.empty()) continue;
    // Pixel i covers [i − ½, i + ½]; sub-pixel k of the canvas has its centre at (k + ½)/ss − ½.
    constexpr int kShift = 8;
    canvas_points.clear();
    for (const cv::Point2d& uv : projected) {
      const double cx = ((uv.x - box.x) + 0.5) * kSupersample - 0.5;
      const double cy = ((uv.y - box.y) + 0.5) * kSupersample - 0.5;
      canvas_points.emplace_back(cvRound(cx * (1 << kShift)), cvRound(cy * (1 << kShift)));
    }
    canvas_.create(box.height * kSupersample, box.width * kSupersample, CV_8UC1);
    canvas_.setTo(cv::Scalar(0));
    const cv::Point* pts = canvas_points.data();
    const int n = static_cast<int>(canvas_points.size());
    cv::fillPoly(canvas_, &pts, &n, 1, cv::Scalar(255), cv::LINE_8, kShift);
    cv::resize(canvas_, coverage_, box.size(), 0, 0, cv::INTER_AREA);
    for (int v = 0; v < box.height; ++v) {
      float* a = albedo_.ptr<float>(box.y + v) + box.x;
      const uint8_t* c = coverage_.ptr<uint8_t>(v);
      for (int u = 0; u < box.width; ++u) a[u] += static_cast<float>((shape.grey - a[u]) * (c[u] * (1.0 / 255.0)));
    }
  }
  out.create(size, CV_8UC1);
  const size_t pixels = static_cast<size_t>(size.area());
  const int8_t* noise = noise_.data() + static_cast<size_t>(rng_.uniform(0.0, static_cast<double>(noise_.size() - pixels)));
  const float gain = static_cast<float>(exposure);
  for (int v = 0; v < size.height; ++v) {
    const float* a = albedo_.ptr<float>(v);
    const float* l = lighting.ptr<float>(v);
    uint8_t* o = out.ptr<uint8_t>(v);
    for (int u = 0; u < size.width; ++u, ++noise) {
      const float value = a[u] * l[u] * gain + static_cast<float>(*noise);
      o[u] = static_cast<uint8_t>(std::clamp(value + 0.5f, 0.0f, 255.0f));
    }
  }
}

}  // namespace quad::sim
