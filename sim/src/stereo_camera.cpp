#include "quad/sim/stereo_camera.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace quad::sim {

namespace {

constexpr int kCoverageRows = 16;     // sample lines per pixel row for the edge coverage
constexpr int kSegmentsPerEdge = 24;  // straight floor edges are curves in the distorted image
constexpr size_t kNoiseTable = size_t{1} << 21;
constexpr double kFieldPeriod = 1.0 / 60.0;  // analog video: two fields per 1/30 s frame
constexpr double kBlurStepPx = 0.5;          // image motion between two sub-exposures at most
constexpr int kMaxBlurSamples = 16;

std::vector<Eigen::Vector2d> regular_polygon(const Eigen::Vector2d& centre, double radius, int sides, double rotation) {
  std::vector<Eigen::Vector2d> v;
  for (int i = 0; i < sides; ++i) {
    const double a = rotation + 2.0 * M_PI * i / sides;
    v.emplace_back(centre + radius * Eigen::Vector2d(std::cos(a), std::sin(a)));
  }
  return v;
}

// Vignetting: brightness falls off with the square of the distance from the principal point.
cv::Mat lighting_map(const LensParams& lens, cv::Size size, double vignetting) {
  cv::Mat light(size, CV_32F);
  const double cx = lens.cx, cy = lens.cy;
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

VehiclePose interpolate(const VehiclePose& a, const VehiclePose& b, double f) {
  return VehiclePose{a.p_ned + f * (b.p_ned - a.p_ned), a.q_ib.slerp(f, b.q_ib)};
}

// Adds weight × the length of [xa, xb] that falls in each pixel of a coverage row (pixel u of the image
// covers [u − ½, u + ½]; the row starts at pixel x0 and is `width` long).
void add_span(float* row, int x0, int width, double xa, double xb, double weight) {
  const double a = std::max(xa - x0 + 0.5, 0.0), b = std::min(xb - x0 + 0.5, static_cast<double>(width));
  if (!(b > a)) return;
  const int ia = static_cast<int>(a), ib = static_cast<int>(b);
  if (ia == ib) {
    row[ia] += static_cast<float>((b - a) * weight);
    return;
  }
  row[ia] += static_cast<float>((ia + 1 - a) * weight);
  for (int i = ia + 1; i < ib; ++i) row[i] += static_cast<float>(weight);
  if (ib < width) row[ib] += static_cast<float>((b - ib) * weight);
}

// Each pixel's covered fraction (CV_32F) of `box` by the polygon (even-odd rule): exact along x, sampled
// on kCoverageRows lines per pixel row at the centres of equal slices. Unbiased for every edge direction
// and sub-pixel phase, where a fill of a supersampled canvas (cv::fillPoly draws the outline into it)
// grows every shape by half a sub-pixel, by an amount that depends on the edge's direction.
void polygon_coverage(const std::vector<Eigen::Vector2d>& polygon, const cv::Rect& box, std::vector<double>& crossings,
                      std::vector<std::vector<int>>& rows, cv::Mat& coverage) {
  coverage.create(box.size(), CV_32F);
  coverage.setTo(cv::Scalar(0.0));
  const int n = static_cast<int>(polygon.size());
  // Each edge listed under the pixel rows it spans, so that a line tests only its row's edges.
  rows.resize(static_cast<size_t>(box.height));
  for (std::vector<int>& r : rows) r.clear();
  for (int i = 0; i < n; ++i) {
    const double y0 = std::min(polygon[i].y(), polygon[(i + 1) % n].y()) - box.y + 0.5;
    const double y1 = std::max(polygon[i].y(), polygon[(i + 1) % n].y()) - box.y + 0.5;
    const int first = std::max(static_cast<int>(std::floor(y0)), 0), last = std::min(static_cast<int>(std::floor(y1)), box.height - 1);
    for (int v = first; v <= last; ++v) rows[static_cast<size_t>(v)].push_back(i);
  }
  constexpr double kWeight = 1.0 / kCoverageRows;
  for (int v = 0; v < box.height; ++v) {
    float* row = coverage.ptr<float>(v);
    for (int k = 0; k < kCoverageRows; ++k) {
      const double y = box.y + v - 0.5 + (k + 0.5) * kWeight;
      crossings.clear();
      for (int i : rows[static_cast<size_t>(v)]) {
        const Eigen::Vector2d& a = polygon[i];
        const Eigen::Vector2d& b = polygon[(i + 1) % n];
        if ((a.y() <= y) != (b.y() <= y)) crossings.push_back(a.x() + (y - a.y()) * (b.x() - a.x()) / (b.y() - a.y()));
      }
      std::sort(crossings.begin(), crossings.end());
      for (size_t s = 0; s + 1 < crossings.size(); s += 2) add_span(row, box.x, box.width, crossings[s], crossings[s + 1], kWeight);
    }
  }
}

}  // namespace

std::vector<Eigen::Vector2d> landing_star_outline(double tip_to_tip, double inner_ratio) {
  std::vector<Eigen::Vector2d> outline;
  const double tip = 0.5 * tip_to_tip;
  for (int i = 0; i < 8; ++i) {
    const double angle = i * M_PI / 4.0;
    const double r = i % 2 == 0 ? tip : inner_ratio * tip;
    outline.emplace_back(r * std::cos(angle), r * std::sin(angle));
  }
  return outline;
}

std::vector<FloorShape> make_floor_scene(const CameraParams& params, Rng rng) {
  std::vector<FloorShape> scene;
  scene.push_back(FloorShape{landing_star_outline(params.star_tip_to_tip_m, params.star_inner_ratio), params.star_grey});
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

void paint_shapes(const LensParams& lens, double valid_radius, const CameraPose& pose, const std::vector<FloorShape>& shapes,
                  size_t first, cv::Mat& albedo, std::vector<double>& crossings, cv::Mat& coverage) {
  const cv::Size size = albedo.size();
  const cv::Rect image_rect(0, 0, size.width, size.height);
  std::vector<Eigen::Vector2d> projected;
  std::vector<std::vector<int>> rows;
  for (size_t s = first; s < shapes.size(); ++s) {
    const FloorShape& shape = shapes[s];
    projected.clear();
    bool visible = true;
    for (size_t i = 0; i < shape.outline.size() && visible; ++i) {
      const Eigen::Vector2d a = shape.outline[i], b = shape.outline[(i + 1) % shape.outline.size()];
      for (int k = 0; k < kSegmentsPerEdge; ++k) {
        const Eigen::Vector2d q = a + (b - a) * (static_cast<double>(k) / kSegmentsPerEdge);
        const auto uv = project_lens(lens, valid_radius, pose.R * Eigen::Vector3d(q.x(), q.y(), 0.0) + pose.t);
        if (!uv) {
          visible = false;
          break;
        }
        projected.push_back(*uv);
      }
    }
    if (!visible) continue;
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (const Eigen::Vector2d& uv : projected) {
      x0 = std::min(x0, uv.x()); y0 = std::min(y0, uv.y()); x1 = std::max(x1, uv.x()); y1 = std::max(y1, uv.y());
    }
    if (x1 < -1.0 || y1 < -1.0 || x0 > size.width || y0 > size.height) continue;
    const cv::Rect box = cv::Rect(cv::Point(static_cast<int>(std::floor(std::max(x0, -1.0))) - 1,
                                            static_cast<int>(std::floor(std::max(y0, -1.0))) - 1),
                                  cv::Point(static_cast<int>(std::ceil(std::min(x1, size.width + 1.0))) + 2,
                                            static_cast<int>(std::ceil(std::min(y1, size.height + 1.0))) + 2)) &
                         image_rect;
    if (box.empty()) continue;
    polygon_coverage(projected, box, crossings, rows, coverage);
    for (int v = 0; v < box.height; ++v) {
      float* a = albedo.ptr<float>(box.y + v) + box.x;
      const float* c = coverage.ptr<float>(v);
      for (int u = 0; u < box.width; ++u) a[u] += static_cast<float>((shape.grey - a[u]) * c[u]);
    }
  }
}

StereoCameraRenderer::StereoCameraRenderer(const CameraParams& params, const SimStereoRig& rig, std::vector<FloorShape> scene,
                                           Rng rng)
    : p_(params), rig_(rig), scene_(std::move(scene)), scene_shapes_(scene_.size()), rng_(std::move(rng)) {
  left_ = make_view(rig_.left, rig_.left_mount);
  right_ = make_view(rig_.right, rig_.right_mount);
  if (!p_.floor_texture.empty()) texture_.emplace(p_.floor_texture, p_.floor_texture_m, p_.floor_grey, p_.floor_texture_contrast);
  noise_.resize(kNoiseTable);
  for (int8_t& n : noise_) n = static_cast<int8_t>(std::clamp(std::lround(rng_.normal(p_.noise_grey)), -127L, 127L));
}

StereoCameraRenderer::View StereoCameraRenderer::make_view(const LensParams& lens, const CameraMountModel& mount) const {
  View view;
  view.lens = lens;
  view.mount = mount;
  view.valid_radius = lens_fold_radius(lens);
  const cv::Size size(rig_.width, rig_.height);
  view.lighting = lighting_map(lens, size, p_.vignetting);
  if (p_.floor_texture.empty()) return view;
  view.rays.create(size, CV_32FC2);
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < size.height; ++v) {
    cv::Vec2f* row = view.rays.ptr<cv::Vec2f>(v);
    for (int u = 0; u < size.width; ++u) {
      const auto xy = unproject_lens(lens, view.valid_radius, Eigen::Vector2d(u, v));
      row[u] = xy ? cv::Vec2f(static_cast<float>(xy->x()), static_cast<float>(xy->y())) : cv::Vec2f(kNan, kNan);
    }
  }
  return view;
}

void StereoCameraRenderer::set_decoy(const std::optional<Eigen::Vector2d>& north_east) {
  scene_.resize(scene_shapes_);
  if (!north_east || scene_.empty()) return;
  FloorShape decoy = scene_.front();
  for (Eigen::Vector2d& v : decoy.outline) v += *north_east;
  scene_.push_back(std::move(decoy));
}

void StereoCameraRenderer::render(const Eigen::Vector3d& p_ned, const Eigen::Quaterniond& q_ib, bool hide_star, cv::Mat& left,
                                  cv::Mat& right) {
  const VehiclePose still{p_ned, q_ib};
  render([&](double) { return still; }, 0.0, hide_star, left, right);
}

void StereoCameraRenderer::render(const PoseAtTime& pose_at, double t, bool hide_star, cv::Mat& left, cv::Mat& right) {
  // Exposure wanders slowly (auto-exposure hunting, clouds): an AR(1) walk of unit variance.
  exposure_walk_ = 0.9 * exposure_walk_ + std::sqrt(1.0 - 0.81) * rng_.normal();
  const double exposure = std::clamp(1.0 + p_.exposure_variation * exposure_walk_, 0.5, 1.5);
  render_view(left_, pose_at, t, hide_star, exposure, left);
  render_view(right_, pose_at, t, hide_star, exposure, right);
}

void StereoCameraRenderer::floor_albedo(const View& view, const VehiclePose& pose, bool hide_star, int first_row, int row_step,
                                        cv::Mat& albedo) {
  const CameraPose camera = camera_pose_over_floor(view.mount, pose.p_ned, pose.q_ib);
  albedo.create(rig_.height, rig_.width, CV_32F);
  if (texture_) {
    texture_->fill(view.rays, camera, view.lens.fy, first_row, row_step, albedo);
  } else {
    albedo.setTo(cv::Scalar(p_.floor_grey));
  }
  paint_shapes(view.lens, view.valid_radius, camera, scene_, hide_star ? 1 : 0, albedo, crossings_, coverage_);
}

int StereoCameraRenderer::blur_samples(const View& view, const VehiclePose& start, const VehiclePose& end) const {
  // Image motion over the shutter time: the floor point on the optical axis at the start, seen at the end.
  const CameraPose a = camera_pose_over_floor(view.mount, start.p_ned, start.q_ib);
  const CameraPose b = camera_pose_over_floor(view.mount, end.p_ned, end.q_ib);
  const Eigen::Vector3d centre = -a.R.transpose() * a.t, axis = a.R.transpose() * Eigen::Vector3d::UnitZ();
  if (axis.z() <= 1e-3) return 1;
  const Eigen::Vector3d on_floor = centre + (-centre.z() / axis.z()) * axis;
  const Eigen::Vector3d seen = b.R * on_floor + b.t;
  if (seen.z() <= 1e-3) return kMaxBlurSamples;
  const double motion_px = view.lens.fy * std::hypot(seen.x() / seen.z(), seen.y() / seen.z());
  return std::clamp(static_cast<int>(std::ceil(motion_px / kBlurStepPx)), 1, kMaxBlurSamples);
}

void StereoCameraRenderer::render_view(const View& view, const PoseAtTime& pose_at, double t, bool hide_star, double exposure,
                                       cv::Mat& out) {
  const int fields = p_.interlaced ? 2 : 1;
  sum_.create(rig_.height, rig_.width, CV_32F);
  for (int field = 0; field < fields; ++field) {
    const double end_t = t - (fields - 1 - field) * kFieldPeriod;
    const VehiclePose end = pose_at(end_t);
    const VehiclePose start = p_.exposure_s > 0.0 ? pose_at(end_t - p_.exposure_s) : end;
    const int samples = p_.exposure_s > 0.0 ? blur_samples(view, start, end) : 1;
    last_blur_samples_ = samples;
    const int first_row = field;  // even rows: the first field
    for (int k = 0; k < samples; ++k) {
      // Sub-exposures at the middles of equal slices of the shutter time.
      floor_albedo(view, samples == 1 ? end : interpolate(start, end, (k + 0.5) / samples), hide_star, first_row, fields, albedo_);
      for (int v = first_row; v < rig_.height; v += fields) {
        const float* a = albedo_.ptr<float>(v);
        float* s = sum_.ptr<float>(v);
        const float w = 1.0f / static_cast<float>(samples);
        if (k == 0) {
          for (int u = 0; u < rig_.width; ++u) s[u] = a[u] * w;
        } else {
          for (int u = 0; u < rig_.width; ++u) s[u] += a[u] * w;
        }
      }
    }
  }
  expose(view, sum_, exposure, out);
}

void StereoCameraRenderer::expose(const View& view, const cv::Mat& albedo, double exposure, cv::Mat& out) {
  const cv::Size size = albedo.size();
  out.create(size, CV_8UC1);
  const size_t pixels = static_cast<size_t>(size.area());
  const int8_t* noise = noise_.data() + static_cast<size_t>(rng_.uniform(0.0, static_cast<double>(noise_.size() - pixels)));
  const float gain = static_cast<float>(exposure);
  for (int v = 0; v < size.height; ++v) {
    const float* a = albedo.ptr<float>(v);
    const float* l = view.lighting.ptr<float>(v);
    uint8_t* o = out.ptr<uint8_t>(v);
    for (int u = 0; u < size.width; ++u, ++noise) {
      const float value = a[u] * l[u] * gain + static_cast<float>(*noise);
      o[u] = static_cast<uint8_t>(std::clamp(value + 0.5f, 0.0f, 255.0f));
    }
  }
  if (p_.jpeg_quality > 0) {
    // The capture device's compression: encode and decode, as the station would receive it.
    std::vector<uint8_t> jpeg;
    cv::imencode(".jpg", out, jpeg, {cv::IMWRITE_JPEG_QUALITY, p_.jpeg_quality});
    out = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
  }
}

void StereoCameraRenderer::render_target(const CameraPose& target_in_left, const std::vector<FloorShape>& shapes,
                                         double background, cv::Mat& left, cv::Mat& right) {
  const Eigen::Matrix3d R = rig_.R_right_left();
  const Eigen::Vector3d T = rig_.T_right_left();
  const CameraPose in_right{R * target_in_left.R, R * target_in_left.t + T};
  for (int i = 0; i < 2; ++i) {
    const View& view = i == 0 ? left_ : right_;
    albedo_.create(rig_.height, rig_.width, CV_32F);
    albedo_.setTo(cv::Scalar(background));
    paint_shapes(view.lens, view.valid_radius, i == 0 ? target_in_left : in_right, shapes, 0, albedo_, crossings_, coverage_);
    expose(view, albedo_, 1.0, i == 0 ? left : right);
  }
}

}  // namespace quad::sim
