#include "eval_scene.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "eval_effects.h"
#include "eval_render.h"
#include "eval_shapes.h"

namespace vision_eval {
namespace {

constexpr int kSupersample = 2;
constexpr double kStarTip = 0.20;   // the landing star: 0.40 m tip to tip
constexpr double kFieldPeriodS = 1.0 / 60.0;

cv::Matx33d rot_z(double a) {
  return cv::Matx33d(std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1);
}

cv::Matx33d axis_angle(cv::Vec3d axis, double angle) {
  cv::Matx33d R;
  cv::Rodrigues(cv::Matx31d(axis[0] * angle, axis[1] * angle, axis[2] * angle), R);
  return R;
}

// Densified outline (edges sampled) so that a curved (distorted) edge is checked, not only its vertices.
std::vector<cv::Point3d> dense(const Outline& outline) {
  std::vector<cv::Point3d> pts;
  for (size_t i = 0; i < outline.size(); ++i) {
    const cv::Point2d a = outline[i], b = outline[(i + 1) % outline.size()];
    for (int k = 0; k < 6; ++k) {
      const cv::Point2d p = a + (b - a) * (k / 6.0);
      pts.emplace_back(p.x, p.y, 0.0);
    }
  }
  return pts;
}

cv::Mat load_photo(const std::string& path) {
  cv::Mat grey = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (grey.empty()) throw std::runtime_error(path + ": cannot read the floor photograph");
  // Stretch the 2nd..98th percentile to [0, 1] so every photograph has a comparable contrast range.
  cv::Mat sorted = grey.reshape(1, 1).clone();
  cv::sort(sorted, sorted, cv::SORT_ASCENDING);
  const double lo = sorted.at<uchar>(0, static_cast<int>(0.02 * (sorted.cols - 1)));
  const double hi = sorted.at<uchar>(0, static_cast<int>(0.98 * (sorted.cols - 1)));
  cv::Mat out;
  grey.convertTo(out, CV_32F, 1.0 / std::max(hi - lo, 1.0), -lo / std::max(hi - lo, 1.0));
  return cv::min(cv::max(out, 0.0), 1.0);
}

}  // namespace

std::vector<Condition> all_conditions() {
  std::vector<Condition> c(8);
  c[0].name = "plain";
  c[0].photo_floor = false;
  c[1].name = "photo_floor";
  c[2].name = "motion_blur";
  c[2].max_blur_px = 6.0;
  c[3].name = "interlaced";
  c[3].interlaced = true;
  c[3].max_blur_px = 3.0;
  c[4].name = "jpeg";
  c[4].jpeg = true;
  c[5].name = "lighting";
  c[5].harsh_lighting = true;
  c[6].name = "analog_faults";
  c[6].analog_faults = true;
  c[7] = Condition{"combined", true, 6.0, true, true, true, true};
  return c;
}

struct PairGenerator::Layout {
  CameraPose left, right;
  std::vector<Outline> outlines;
  std::vector<std::pair<cv::Point2d, double>> occupied;  // centre, radius
  cv::Point2d star_centre;
  bool star = false, cut = false;
};

PairGenerator::PairGenerator(const EvalRig& rig, const std::vector<std::string>& photo_paths)
    : rig_(rig), left_grid_(rig.left, kSupersample), right_grid_(rig.right, kSupersample) {
  for (const std::string& path : photo_paths) {
    photos_.push_back(load_photo(path));
    photo_names_.push_back(std::filesystem::path(path).filename().string());
  }
}

CameraPose PairGenerator::random_pose(double height) {
  // Camera axes start aligned with the floor frame (z into the floor), turned about the vertical by a
  // random heading, then tilted by up to 20° about a random horizontal axis.
  const double heading = rng_.uniform(0.0, 2.0 * CV_PI);
  const double tilt = rng_.uniform(0.0, 20.0) * CV_PI / 180.0;
  const double azimuth = rng_.uniform(0.0, 2.0 * CV_PI);
  const cv::Matx33d R_pc = axis_angle(cv::Vec3d(std::cos(azimuth), std::sin(azimuth), 0.0), tilt) * rot_z(heading);
  CameraPose pose;
  pose.R_cp = R_pc.t();
  pose.C = cv::Vec3d(rng_.uniform(-1.0, 1.0), rng_.uniform(-1.0, 1.0), -height);
  return pose;
}

bool PairGenerator::ray_to_floor(const CameraPose& pose, cv::Point2d pixel, cv::Point2d& floor) const {
  std::vector<cv::Point2d> in{pixel}, out;
  cv::undistortPoints(in, out, rig_.left.K, rig_.left.D, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-14));
  const cv::Vec3d d = pose.R_cp.t() * cv::Vec3d(out[0].x, out[0].y, 1.0);
  const double s = -pose.C[2] / d[2];
  if (!(s > 0.0)) return false;
  floor = cv::Point2d(pose.C[0] + s * d[0], pose.C[1] + s * d[1]);
  return true;
}

double PairGenerator::outline_inside(const EvalCamera& camera, const CameraPose& pose,
                                  const std::vector<cv::Point2d>& outline, double margin_px) const {
  const std::vector<cv::Point3d> pts = dense(outline);
  const std::vector<cv::Point2f> px = project(camera, pose, pts);
  int inside = 0;
  for (size_t i = 0; i < px.size(); ++i) {
    const cv::Vec3d pc = pose.R_cp * (cv::Vec3d(pts[i].x, pts[i].y, 0.0) - pose.C);
    if (pc[2] > 0.05 && px[i].x >= margin_px && px[i].y >= margin_px && px[i].x <= camera.size.width - 1 - margin_px &&
        px[i].y <= camera.size.height - 1 - margin_px) {
      ++inside;
    }
  }
  return inside / static_cast<double>(px.size());
}

bool PairGenerator::place_star(const CameraPose& left, Layout& layout) {
  for (int attempt = 0; attempt < 60; ++attempt) {
    const cv::Point2d pixel(rng_.uniform(40.0, rig_.left.size.width - 40.0), rng_.uniform(40.0, rig_.left.size.height - 40.0));
    cv::Point2d centre;
    if (!ray_to_floor(left, pixel, centre)) continue;
    const Outline star = four_point_star(centre, kStarTip, rng_.uniform(0.0, 2.0 * CV_PI));
    if (outline_inside(rig_.left, left, star, 4.0) < 1.0 || outline_inside(rig_.right, layout.right, star, 4.0) < 1.0) {
      continue;
    }
    layout.outlines.push_back(star);
    layout.occupied.emplace_back(centre, kStarTip);
    layout.star_centre = centre;
    layout.star = true;
    return true;
  }
  return false;
}

bool PairGenerator::place_cut_star(const CameraPose& left, Layout& layout) {
  // Centre near an image border so that 15–70 % of the outline falls outside one of the images.
  for (int attempt = 0; attempt < 60; ++attempt) {
    const int side = rng_.uniform(0, 4);
    const double w = rig_.left.size.width, h = rig_.left.size.height;
    const double t = rng_.uniform(0.1, 0.9), inset = rng_.uniform(-20.0, 30.0);
    const cv::Point2d pixel = side == 0 ? cv::Point2d(inset, t * h)
                              : side == 1 ? cv::Point2d(w - 1 - inset, t * h)
                              : side == 2 ? cv::Point2d(t * w, inset)
                                          : cv::Point2d(t * w, h - 1 - inset);
    cv::Point2d centre;
    if (!ray_to_floor(left, pixel, centre)) continue;
    bool clear = true;
    for (const auto& [c, r] : layout.occupied) clear = clear && cv::norm(c - centre) > r + kStarTip + 0.05;
    if (!clear) continue;
    const Outline star = four_point_star(centre, kStarTip, rng_.uniform(0.0, 2.0 * CV_PI));
    const double in_left = outline_inside(rig_.left, left, star, 0.0);
    const double in_right = outline_inside(rig_.right, layout.right, star, 0.0);
    if (std::min(in_left, in_right) > 0.85 || std::max(in_left, in_right) < 0.3) continue;
    layout.outlines.push_back(star);
    layout.occupied.emplace_back(centre, kStarTip);
    layout.cut = true;
    return true;
  }
  return false;
}

void PairGenerator::place_decoys(const CameraPose& left, Layout& layout) {
  const int wanted = rng_.uniform(2, 5);
  int placed = 0;
  for (int attempt = 0; attempt < 80 && placed < wanted; ++attempt) {
    const cv::Point2d pixel(rng_.uniform(0.0, rig_.left.size.width - 1.0), rng_.uniform(0.0, rig_.left.size.height - 1.0));
    cv::Point2d centre;
    if (!ray_to_floor(left, pixel, centre)) continue;
    const double size = rng_.uniform(0.14, 0.24);
    const double yaw = rng_.uniform(0.0, 2.0 * CV_PI);
    Outline o;
    switch ((placed + layout.outlines.size()) % 4) {
      case 0: o = five_point_star(centre, size, rng_.uniform(0.38, 0.5), yaw); break;
      case 1: o = square(centre, 1.2 * size, yaw); break;
      case 2: o = disc(centre, 0.7 * size); break;
      default: o = plus_cross(centre, size, rng_.uniform(0.25, 0.4) * size, yaw); break;
    }
    const double radius = outline_radius(o, centre);
    bool clear = true;
    for (const auto& [c, r] : layout.occupied) clear = clear && cv::norm(c - centre) > r + radius + 0.05;
    if (!clear) continue;
    layout.outlines.push_back(o);
    layout.occupied.emplace_back(centre, radius);
    ++placed;
  }
}

void PairGenerator::reseed(uint64_t seed) {
  rng_ = cv::RNG(seed);
  previous_ = StereoImages{};
}

StereoImages PairGenerator::make(const Condition& condition, bool want_star) {
  if (condition.analog_faults && !previous_.left.empty() && previous_.truth.star_in_view == want_star &&
      rng_.uniform(0.0, 1.0) < 0.08) {
    // A frozen link: the capture device repeats the last pair (the truth is the repeated pair's).
    previous_.truth.frozen = true;
    return previous_;
  }
  Layout layout;
  StereoImages out;
  PairTruth& t = out.truth;
  for (;;) {
    layout = Layout{};
    t.height_m = rng_.uniform(0.5, 2.6);
    layout.left = random_pose(t.height_m);
    layout.right = right_pose(rig_, layout.left);
    if (want_star && !place_star(layout.left, layout)) continue;
    const bool cut = want_star ? rng_.uniform(0.0, 1.0) < 0.25 : rng_.uniform(0.0, 1.0) < 0.5;
    if (cut && !place_cut_star(layout.left, layout)) continue;
    break;
  }
  place_decoys(layout.left, layout);
  t.star_in_view = layout.star;
  t.star_cut = layout.cut;
  t.decoys = static_cast<int>(layout.outlines.size()) - (layout.star ? 1 : 0) - (layout.cut ? 1 : 0);
  t.tilt_deg = std::acos(std::clamp(layout.left.R_cp(2, 2), -1.0, 1.0)) * 180.0 / CV_PI;
  if (layout.star) {
    const cv::Vec3d P(layout.star_centre.x, layout.star_centre.y, 0.0);
    t.star_left = layout.left.R_cp * (P - layout.left.C);
    t.range_m = cv::norm(t.star_left);
    t.star_normal = layout.left.R_cp * cv::Vec3d(0.0, 0.0, 1.0);  // the floor frame's z points into the floor
  }

  // The floor's look and the light.
  FloorLook floor;
  floor.shape_albedo = rng_.uniform(0.06, 0.3);
  t.floor = "plain";
  if (condition.photo_floor && !photos_.empty()) {
    const int k = rng_.uniform(0, static_cast<int>(photos_.size()));
    floor.texture = photos_[k];
    t.floor = photo_names_[k];
    floor.contrast = rng_.uniform(0.2, 0.5);
    const double metres_per_photo_width = rng_.uniform(0.6, 2.0);
    const double s = floor.texture.cols / metres_per_photo_width, a = rng_.uniform(0.0, 2.0 * CV_PI);
    floor.plane_to_texture = cv::Matx23d(s * std::cos(a), -s * std::sin(a), rng_.uniform(0.0, 500.0),
                                         s * std::sin(a), s * std::cos(a), rng_.uniform(0.0, 500.0));
  }
  Lighting light;
  light.level = rng_.uniform(120.0, 235.0) / (1.0 + (condition.harsh_lighting ? 0.35 : 0.0));
  const double g = condition.harsh_lighting ? rng_.uniform(0.15, 0.6) : rng_.uniform(0.0, 0.2);
  const double ga = rng_.uniform(0.0, 2.0 * CV_PI);
  light.gradient = cv::Vec2d(g * std::cos(ga), g * std::sin(ga)) / t.height_m;
  light.vignetting = rng_.uniform(0.0, 0.3);
  const cv::Point2d around = layout.star ? layout.star_centre : cv::Point2d(layout.left.C[0], layout.left.C[1]);
  if (condition.harsh_lighting) {
    light.spot_centre = around + cv::Point2d(rng_.uniform(-0.5, 0.5), rng_.uniform(-0.5, 0.5)) * t.height_m;
    light.spot_gain = rng_.uniform(0.2, 0.7);
    light.spot_sigma = rng_.uniform(0.2, 0.6) * t.height_m;
    light.shadow = true;  // its edge passes within 0.15 m of the star's centre
    const double na = rng_.uniform(0.0, 2.0 * CV_PI);
    light.shadow_normal = cv::Vec2d(std::cos(na), std::sin(na));
    light.shadow_offset = light.shadow_normal.dot(cv::Vec2d(around.x, around.y)) + rng_.uniform(-0.15, 0.15);
    light.shadow_softness = rng_.uniform(0.005, 0.08);
    light.shadow_depth = rng_.uniform(0.3, 0.6);
  }
  std::vector<CoverageCanvas> canvases;
  for (const Outline& o : layout.outlines) canvases.push_back(draw_outlines({o}, std::max(0.0004, t.height_m / 1500.0)));
  cv::Mat views[2] = {render_view(left_grid_, kSupersample, layout.left, floor, canvases, light),
                      render_view(right_grid_, kSupersample, layout.right, floor, canvases, light)};
  degrade(condition, layout, views, out);
  previous_ = out;
  previous_.left = out.left.clone();
  previous_.right = out.right.clone();
  return out;
}

void PairGenerator::degrade(const Condition& condition, const Layout& layout, cv::Mat views[2], StereoImages& out) {
  PairTruth& t = out.truth;
  // One motion for the rig: the same image-space direction in both cameras (they look the same way).
  const double direction = rng_.uniform(0.0, 2.0 * CV_PI);
  t.blur_px = condition.max_blur_px > 0.0 ? rng_.uniform(0.0, condition.max_blur_px) : 0.0;
  t.interlaced = condition.interlaced;
  t.field_shift_px = condition.interlaced ? rng_.uniform(0.0, 6.0) : 0.0;
  t.skew_px = condition.analog_faults ? rng_.uniform(-10.0, 10.0) : 0.0;
  t.snow = condition.analog_faults && rng_.uniform(0, 2) ? rng_.uniform(0.002, 0.02) : 0.0;
  t.sync_bands = condition.analog_faults ? rng_.uniform(0, 4) : 0;
  t.jpeg_quality = condition.jpeg ? rng_.uniform(50, 91) : 0;
  const double noise = rng_.uniform(1.0, 3.0);
  const CameraPose* poses[2] = {&layout.left, &layout.right};
  const EvalCamera* cameras[2] = {&rig_.left, &rig_.right};
  cv::Mat* images[2] = {&out.left, &out.right};
  for (int i = 0; i < 2; ++i) {
    cv::Mat v = motion_blur(views[i], t.blur_px, direction);
    if (t.interlaced) v = interlace(v, cv::Point2d(std::cos(direction), std::sin(direction)) * t.field_shift_px);
    if (t.skew_px != 0.0) {
      // The truth time is when the star's row is read: the skew is zero there.
      double zero_row = 0.5 * v.rows;
      if (layout.star) {
        zero_row = project(*cameras[i], *poses[i], {cv::Point3d(layout.star_centre.x, layout.star_centre.y, 0.0)})[0].y;
      }
      v = rolling_skew(v, t.skew_px, zero_row);
    }
    *images[i] = quantise(v, noise, rng_);
    if (t.snow > 0.0) rf_snow(*images[i], t.snow, rng_);
    if (t.sync_bands > 0) lost_sync(*images[i], t.sync_bands, rng_);
  }
}

std::vector<StereoImages> chessboard_views(const EvalRig& rig, int count, int cols, int rows, double square_m,
                                           uint64_t seed) {
  cv::RNG rng(seed);
  const RayGrid left_grid(rig.left, kSupersample), right_grid(rig.right, kSupersample);
  const std::vector<CoverageCanvas> board{draw_chessboard(cols + 1, rows + 1, square_m, 0.0003)};
  const cv::Point2d board_centre(0.5 * (cols - 1) * square_m, 0.5 * (rows - 1) * square_m);
  std::vector<cv::Point3d> corners;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) corners.emplace_back(i * square_m, j * square_m, 0.0);
  }
  std::vector<StereoImages> views;
  while (static_cast<int>(views.size()) < count) {
    // The board tilted by up to 40° (every third view at least 20°), 0.4–0.9 m away, its centre on a pixel
    // drawn over the whole left image, so that the boards reach into the corners as a careful calibration
    // does (the lens model is then fitted, not extrapolated, where the wide lens bends most).
    const double tilt = (views.size() % 3 == 0 ? rng.uniform(20.0, 40.0) : rng.uniform(0.0, 40.0)) * CV_PI / 180.0;
    const double az = rng.uniform(0.0, 2.0 * CV_PI);
    const cv::Matx33d R_pc = axis_angle(cv::Vec3d(std::cos(az), std::sin(az), 0.0), tilt) * rot_z(rng.uniform(-0.4, 0.4));
    const double distance = rng.uniform(0.4, 0.9);
    const std::vector<cv::Point2d> aim{{rng.uniform(0.0, 1.0) * rig.left.size.width, rng.uniform(0.0, 1.0) * rig.left.size.height}};
    std::vector<cv::Point2d> aim_ray;
    cv::undistortPoints(aim, aim_ray, rig.left.K, rig.left.D);
    const cv::Vec3d look = R_pc * cv::normalize(cv::Vec3d(aim_ray[0].x, aim_ray[0].y, 1.0));
    CameraPose left;
    left.R_cp = R_pc.t();
    left.C = cv::Vec3d(board_centre.x, board_centre.y, 0.0) - distance * look;
    if (left.C[2] >= -0.1) continue;
    const CameraPose right = right_pose(rig, left);
    bool inside = true;
    const std::pair<const EvalCamera*, const CameraPose*> both[2] = {{&rig.left, &left}, {&rig.right, &right}};
    for (const auto& [camera, pose] : both) {
      for (const cv::Point2f& p : project(*camera, *pose, corners)) {
        inside = inside && p.x > 15 && p.y > 15 && p.x < camera->size.width - 16 && p.y < camera->size.height - 16;
      }
    }
    if (!inside) continue;
    FloorLook paper;
    paper.shape_albedo = 0.08;
    Lighting light;
    light.level = rng.uniform(170.0, 220.0);
    StereoImages v;
    v.left = quantise(render_view(left_grid, kSupersample, left, paper, board, light), 1.5, rng);
    v.right = quantise(render_view(right_grid, kSupersample, right, paper, board, light), 1.5, rng);
    views.push_back(std::move(v));
  }
  return views;
}

}  // namespace vision_eval
