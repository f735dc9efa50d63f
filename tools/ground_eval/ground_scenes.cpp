#include "ground_scenes.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <sys/stat.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace ground_eval {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kShift = 4;  // sub-pixel bits of the drawing calls
constexpr double kScale = 1 << kShift;

cv::Matx33d rot_x(double a) { return {1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a)}; }
cv::Matx33d rot_y(double a) { return {std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a)}; }
cv::Matx33d rot_z(double a) { return {std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1}; }

cv::Point fixed(const cv::Point2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x * kScale)), static_cast<int>(std::lround(p.y * kScale)));
}

std::vector<cv::Point2d> project(const std::vector<cv::Point3d>& points, const cv::Vec3d& rvec, const cv::Vec3d& tvec,
                                 const SceneCamera& camera) {
  std::vector<cv::Point2d> out;
  cv::projectPoints(points, rvec, tvec, camera.K, camera.distortion, out);
  return out;
}

void make_dir(const std::string& dir) {
  if (::mkdir(dir.c_str(), 0755) != 0 && errno != EEXIST) throw std::runtime_error(dir + ": cannot create");
}

// Uncompressed: the noisy images compress poorly and deflate cost most of the generation time.
void write_png(const std::string& path, const cv::Mat& image) {
  if (!cv::imwrite(path, image, {cv::IMWRITE_PNG_COMPRESSION, 0})) throw std::runtime_error(path + ": cannot write");
}

// A neutral grey room: smooth texture and a few darker and lighter furniture blocks, per camera.
cv::Mat room_background(cv::Size size, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat coarse(12, 16, CV_8U);
  rng.fill(coarse, cv::RNG::UNIFORM, 105, 165);
  cv::Mat grey;
  cv::resize(coarse, grey, size, 0, 0, cv::INTER_CUBIC);
  for (int i = 0; i < 6; ++i) {
    const int w = rng.uniform(60, 260), h = rng.uniform(40, 200);
    const cv::Rect r(rng.uniform(0, size.width - w), rng.uniform(0, size.height - h), w, h);
    grey(r).setTo(rng.uniform(70, 200));
  }
  cv::line(grey, {0, size.height * 2 / 3}, {size.width, size.height * 2 / 3 - 40}, 90, 3, cv::LINE_AA);
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

// Illumination: a global gain, a ramp across the image (a lamp on one side), a white-balance cast per
// camera, sensor noise.
cv::Mat light(const cv::Mat& drawn, double gain, int camera, double noise, cv::RNG& rng) {
  const cv::Vec3f balance = camera % 2 == 0 ? cv::Vec3f(1.08f, 1.0f, 0.92f) : cv::Vec3f(0.93f, 1.0f, 1.06f);
  cv::Mat row(1, drawn.cols, CV_32FC3);
  for (int x = 0; x < drawn.cols; ++x) {
    const float ramp = static_cast<float>(gain * (0.75 + 0.25 * (camera % 2 == 0 ? x : drawn.cols - x) / drawn.cols));
    row.at<cv::Vec3f>(0, x) = ramp * balance;
  }
  cv::Mat f, map;
  drawn.convertTo(f, CV_32FC3);
  cv::repeat(row, drawn.rows, 1, map);
  f = f.mul(map);
  cv::Mat n(f.size(), CV_32FC3);
  rng.fill(n, cv::RNG::NORMAL, 0.0, noise);
  f += n;
  cv::Mat out;
  f.convertTo(out, CV_8UC3);
  return out;
}

// The chessboard drawn through the camera: paper with a one-square margin, black squares. `to_object`
// maps board coordinates (metres) to the frame of rvec/tvec.
template <typename ToObject>
void draw_board(cv::Mat& image, const BoardSpec& board, ToObject to_object, const cv::Vec3d& rvec,
                const cv::Vec3d& tvec, const SceneCamera& camera) {
  const double s = board.square_m;
  auto quad = [&](double x0, double y0, double x1, double y1, const cv::Scalar& colour) {
    const auto p = project({to_object(x0, y0), to_object(x1, y0), to_object(x1, y1), to_object(x0, y1)}, rvec, tvec, camera);
    const std::vector<cv::Point> pts{fixed(p[0]), fixed(p[1]), fixed(p[2]), fixed(p[3])};
    cv::fillConvexPoly(image, pts, colour, cv::LINE_AA, kShift);
  };
  // The paper, 0.75 square beyond the squares, in cells (its edges bend with the lens like the squares).
  const double m = 0.75 * s, x0 = -s - m, y0 = -s - m;
  const double cw = ((board.inner.width + 1) * s + 2 * m) / 12, ch = ((board.inner.height + 1) * s + 2 * m) / 10;
  for (int j = 0; j < 10; ++j) {
    for (int i = 0; i < 12; ++i) {
      quad(x0 + i * cw, y0 + j * ch, x0 + (i + 1) * cw, y0 + (j + 1) * ch, cv::Scalar::all(235));
    }
  }
  for (int j = -1; j < board.inner.height; ++j) {
    for (int i = -1; i < board.inner.width; ++i) {
      if ((i + j + 2) % 2 == 0) quad(i * s, j * s, (i + 1) * s, (j + 1) * s, cv::Scalar::all(25));
    }
  }
}

bool board_inside(const BoardSpec& board, const std::vector<cv::Point3d>& outline, const cv::Vec3d& rvec,
                  const cv::Vec3d& tvec, const SceneCamera& camera, int margin) {
  (void)board;
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  for (const cv::Point3d& p : outline) {
    if ((R * cv::Vec3d(p) + tvec)[2] < 0.3) return false;
  }
  for (const cv::Point2d& p : project(outline, rvec, tvec, camera)) {
    if (p.x < margin || p.y < margin || p.x > camera.size.width - margin || p.y > camera.size.height - margin) return false;
  }
  return true;
}

}  // namespace

cv::Vec4d quaternion_of(const cv::Matx33d& R) {
  // From the rotation vector (angle-axis), a route independent of matrix-element formulas.
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  const double angle = cv::norm(rvec);
  if (angle < 1e-12) return {1, 0, 0, 0};
  const cv::Vec3d axis = rvec / angle;
  cv::Vec4d q(std::cos(angle / 2), axis[0] * std::sin(angle / 2), axis[1] * std::sin(angle / 2), axis[2] * std::sin(angle / 2));
  return q[0] < 0 ? -q : q;
}

std::vector<SceneCamera> make_room_cameras(const RoomSpec& spec) {
  std::vector<SceneCamera> cameras;
  const double f = 0.5 * spec.size.width / std::tan(spec.hfov_deg * kPi / 360.0);
  for (int i = 0; i < spec.cameras; ++i) {
    const double az = (spec.first_azimuth_deg + 90.0 * i) * kPi / 180.0;
    SceneCamera c;
    c.size = spec.size;
    c.K = cv::Matx33d(f, 0, spec.size.width / 2.0 + 3.0 - 2.0 * i, 0, f * 1.002, spec.size.height / 2.0 - 2.0 + 1.5 * i, 0, 0, 1);
    c.distortion = {-0.09 + 0.02 * i, 0.06, 0.0004, -0.0003, 0.0};
    c.centre_ned = cv::Vec3d(spec.distance_m * std::cos(az), spec.distance_m * std::sin(az), -spec.height_m);
    const cv::Vec3d aim(0, 0, -spec.aim_height_m);
    const cv::Vec3d z = cv::normalize(aim - c.centre_ned);          // optical axis
    const cv::Vec3d x = cv::normalize(cv::Vec3d(0, 0, 1).cross(z));  // image right (down × axis)
    const cv::Vec3d y = z.cross(x);                                  // image down
    const cv::Matx33d R_CI(x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]);
    cv::Rodrigues(R_CI, c.rvec);
    c.tvec = -(R_CI * c.centre_ned);
    cameras.push_back(c);
  }
  return cameras;
}

std::vector<int> write_calibration_set(const std::string& dir, const std::vector<SceneCamera>& cameras,
                                       const BoardSpec& board, int free_views, uint64_t seed) {
  make_dir(dir);
  const double s = board.square_m;
  const std::vector<Placement> placements{{"P1", {0.0, 0.0, 0.0}, 0.0},
                                          {"P2", {0.6, 0.3, 0.0}, 90.0},
                                          {"P3", {0.1, 0.9, 0.0}, 0.0},
                                          {"P4", {0.9, -0.3, 0.0}, 180.0}};
  std::ofstream pl(dir + "/placements.csv");
  pl << "placement,north,east,down,yaw_deg\n";
  for (const Placement& p : placements) {
    pl << p.id << "," << p.origin_ned[0] << "," << p.origin_ned[1] << "," << p.origin_ned[2] << "," << p.yaw_deg << "\n";
  }
  std::ofstream views(dir + "/views.csv");
  views << "camera,image,placement\n";
  const std::vector<cv::Point3d> outline_board{{-2 * s, -2 * s, 0}, {(board.inner.width + 1) * s, -2 * s, 0},
                                               {(board.inner.width + 1) * s, (board.inner.height + 1) * s, 0},
                                               {-2 * s, (board.inner.height + 1) * s, 0}};
  cv::RNG rng(seed);
  std::vector<int> written(cameras.size(), 0);
  for (size_t c = 0; c < cameras.size(); ++c) {
    const SceneCamera& cam = cameras[c];
    const cv::Mat background = room_background(cam.size, seed * 31 + c);
    // Held up in front of the camera, tilted: the intrinsics.
    for (int v = 0, tries = 0; v < free_views && tries < 2000; ++tries) {
      const double tilt = rng.uniform(0.35, 0.75), axis = rng.uniform(0.0, 2 * kPi), spin = rng.uniform(-0.4, 0.4);
      const cv::Matx33d R = rot_z(axis) * rot_x(tilt) * rot_z(-axis) * rot_z(spin);
      const double depth = rng.uniform(1.4, 2.6);
      const cv::Vec3d centre(rng.uniform(-0.42, 0.42) * depth, rng.uniform(-0.3, 0.3) * depth, depth);
      const cv::Vec3d mid((board.inner.width - 1) * s / 2, (board.inner.height - 1) * s / 2, 0);
      cv::Vec3d rvec;
      cv::Rodrigues(R, rvec);
      const cv::Vec3d tvec = centre - R * mid;
      if (!board_inside(board, outline_board, rvec, tvec, cam, 10)) continue;
      cv::Mat image = background.clone();
      draw_board(image, board, [](double x, double y) { return cv::Point3d(x, y, 0); }, rvec, tvec, cam);
      cv::GaussianBlur(image, image, cv::Size(3, 3), 0.7);
      const std::string name = "cam" + std::to_string(c) + "_free" + std::to_string(v) + ".png";
      write_png(dir + "/" + name, light(image, rng.uniform(0.8, 1.1), static_cast<int>(c), 2.0, rng));
      views << c << "," << name << ",\n";
      ++v;
      ++written[c];
    }
    // Lying flat at the measured floor placements: the room pose.
    for (const Placement& p : placements) {
      const double yaw = p.yaw_deg * kPi / 180.0;
      auto to_ned = [&](double x, double y) {
        return cv::Point3d(p.origin_ned[0] + std::cos(yaw) * x - std::sin(yaw) * y,
                           p.origin_ned[1] + std::sin(yaw) * x + std::cos(yaw) * y, p.origin_ned[2]);
      };
      std::vector<cv::Point3d> outline;
      for (const cv::Point3d& q : outline_board) outline.push_back(to_ned(q.x, q.y));
      if (!board_inside(board, outline, cam.rvec, cam.tvec, cam, 10)) continue;
      cv::Mat image = background.clone();
      draw_board(image, board, to_ned, cam.rvec, cam.tvec, cam);
      cv::GaussianBlur(image, image, cv::Size(3, 3), 0.7);
      const std::string name = "cam" + std::to_string(c) + "_" + p.id + ".png";
      write_png(dir + "/" + name, light(image, 1.0, static_cast<int>(c), 2.0, rng));
      views << c << "," << name << "," << p.id << "\n";
      ++written[c];
    }
  }
  return written;
}

const char* scenario_name(Scenario s) {
  switch (s) {
    case Scenario::kSingle: return "single";
    case Scenario::kPair: return "pair";
    case Scenario::kCrossing: return "crossing";
    case Scenario::kRetreat: return "retreat";
    case Scenario::kFour: return "four";
  }
  return "?";
}

namespace {

cv::Matx33d attitude(double yaw, double pitch, double roll) { return rot_z(yaw) * rot_y(pitch) * rot_x(roll); }

// Two vehicles passing each other with one on the line of sight of `camera` to the other at time tc:
// the far one at `far`, moving along `along` at `speed`; the near one 0.7 m closer on that line and
// 4 cm higher, moving the other way. Their same-colour markers pass close in that camera's image.
// With `retreat`, both come to the line of sight at tc and turn back (a smooth reversal within ~0.1 s), so
// that each one's constant-velocity prediction runs into the other's markers.
void crossing_pair(std::vector<VehicleState>& out, int first_id, const SceneCamera& camera, const cv::Vec3d& far,
                   const cv::Vec3d& along, double speed, double t, double tc, bool retreat = false) {
  const cv::Vec3d ray = cv::normalize(far - camera.centre_ned);
  const cv::Vec3d near = far - 0.7 * ray + cv::Vec3d(0, 0, -0.04);
  const double d = retreat ? 0.02 - std::hypot(speed * (t - tc), 0.02) : speed * (t - tc);
  const double wobble = 0.05 * std::sin(3.0 * t + first_id);
  out.push_back({first_id, far + d * along, attitude(0.1 * first_id, wobble, -wobble)});
  out.push_back({first_id + 1, near - d * along, attitude(-0.1 * first_id, -wobble, wobble)});
}

}  // namespace

std::vector<VehicleState> scenario_states(Scenario scenario, double t, const std::vector<SceneCamera>& cameras) {
  std::vector<VehicleState> out;
  switch (scenario) {
    case Scenario::kSingle: {
      const double w = 2 * kPi / 4.0;
      const cv::Vec3d p(0.3 + 0.35 * std::sin(w * t), 0.3 + 0.25 * std::sin(2 * w * t), -0.8 - 0.1 * std::sin(w * t));
      out.push_back({1, p, attitude(0.8 * std::sin(0.5 * t), 0.15 * std::sin(2.1 * t), 0.12 * std::cos(1.7 * t))});
      break;
    }
    case Scenario::kPair: {
      for (int i = 0; i < 2; ++i) {
        const cv::Vec3d p(0.3 + 0.02 * std::sin(1.3 * t + i), -0.1 + 0.8 * i + 0.02 * std::cos(1.1 * t + i),
                          -0.8 - 0.01 * std::sin(2.0 * t + i));
        out.push_back({i + 1, p, attitude(0.3 * i, 0.03 * std::sin(2.3 * t + i), 0.03 * std::cos(1.9 * t + i))});
      }
      break;
    }
    case Scenario::kCrossing:
      crossing_pair(out, 1, cameras[0], cv::Vec3d(0.35, 0.0, -0.70), cv::Vec3d(0, 1, 0), 0.25, t, 1.0);
      break;
    case Scenario::kRetreat:
      crossing_pair(out, 1, cameras[0], cv::Vec3d(0.35, 0.0, -0.70), cv::Vec3d(0, 1, 0), 0.3, t, 1.0, true);
      break;
    case Scenario::kFour:
      crossing_pair(out, 1, cameras[0], cv::Vec3d(0.35, 0.0, -0.70), cv::Vec3d(0, 1, 0), 0.25, t, 0.8);
      crossing_pair(out, 3, cameras[1], cv::Vec3d(0.0, 0.35, -1.05), cv::Vec3d(1, 0, 0), 0.25, t, 2.0);
      break;
  }
  return out;
}

std::vector<cv::Mat> render_frame_set(const std::vector<SceneCamera>& cameras, const VehicleModel& model,
                                      const std::vector<VehicleState>& vehicles, double gain, cv::RNG& rng,
                                      std::vector<std::vector<std::array<MarkerTruth, 4>>>& truth) {
  static const cv::Scalar kColour[4] = {{40, 40, 210}, {60, 180, 40}, {200, 80, 30}, {40, 200, 220}};  // BGR
  truth.assign(vehicles.size(), std::vector<std::array<MarkerTruth, 4>>(cameras.size()));
  std::vector<cv::Mat> images;
  for (size_t c = 0; c < cameras.size(); ++c) {
    const SceneCamera& cam = cameras[c];
    cv::Matx33d R_CI;
    cv::Rodrigues(cam.rvec, R_CI);
    thread_local std::vector<cv::Mat> backgrounds;  // the room does not change between frames
    if (backgrounds.size() <= c || backgrounds[c].size() != cam.size) {
      backgrounds.resize(std::max(backgrounds.size(), c + 1));
      backgrounds[c] = room_background(cam.size, 1000 + c);
    }
    cv::Mat image = backgrounds[c].clone();
    cv::Mat ids(cam.size, CV_16S, cv::Scalar(-1));  // which marker (4·vehicle + colour) or -2 (body) a pixel shows
    struct Item {
      double depth;
      int vehicle, marker;  // marker -1: arms and hub
    };
    std::vector<Item> items;
    for (size_t v = 0; v < vehicles.size(); ++v) {
      items.push_back({(R_CI * vehicles[v].ned + cam.tvec)[2], static_cast<int>(v), -1});
      for (int k = 0; k < 4; ++k) {
        const cv::Vec3d p = vehicles[v].ned + vehicles[v].R_IB * model.markers[k];
        items.push_back({(R_CI * p + cam.tvec)[2], static_cast<int>(v), k});
      }
    }
    std::sort(items.begin(), items.end(), [](const Item& a, const Item& b) { return a.depth > b.depth; });
    std::vector<std::array<int, 4>> disc_area(vehicles.size());
    for (const Item& item : items) {
      const VehicleState& s = vehicles[item.vehicle];
      const double f = cam.K(0, 0);
      if (item.marker < 0) {
        std::vector<cv::Point3d> pts{cv::Point3d(s.ned)};
        for (int k = 0; k < 4; ++k) pts.emplace_back(s.ned + s.R_IB * (0.85 * model.markers[k]));
        const auto px = project(pts, cam.rvec, cam.tvec, cam);
        const int thick = std::max(2, static_cast<int>(std::lround(f * 0.012 / item.depth)));
        for (int k = 0; k < 4; ++k) {
          cv::line(image, fixed(px[0]), fixed(px[k + 1]), cv::Scalar::all(45), thick, cv::LINE_AA, kShift);
          cv::line(ids, fixed(px[0]), fixed(px[k + 1]), -2, thick, cv::LINE_8, kShift);
        }
        const int hub = static_cast<int>(std::lround(f * 0.05 / item.depth * kScale));
        cv::circle(image, fixed(px[0]), hub, cv::Scalar::all(35), cv::FILLED, cv::LINE_AA, kShift);
        cv::circle(ids, fixed(px[0]), hub, -2, cv::FILLED, cv::LINE_8, kShift);
        continue;
      }
      const cv::Vec3d p = s.ned + s.R_IB * model.markers[item.marker];
      const cv::Point2d centre = project({cv::Point3d(p)}, cam.rvec, cam.tvec, cam)[0];
      const double radius = f * model.ball_radius_m / item.depth;
      MarkerTruth& t = truth[item.vehicle][c][item.marker];
      t.pixel = centre;
      t.in_image = centre.x > radius && centre.y > radius && centre.x < cam.size.width - radius &&
                   centre.y < cam.size.height - radius && item.depth > 0.1;
      if (item.depth <= 0.1) continue;
      // A ball: the rim darker than the middle (diffuse shading).
      const cv::Scalar base = kColour[item.marker];
      cv::circle(image, fixed(centre), static_cast<int>(radius * kScale), base * 0.75, cv::FILLED, cv::LINE_AA, kShift);
      cv::circle(image, fixed(centre - cv::Point2d(0.15 * radius, 0.15 * radius)), static_cast<int>(0.7 * radius * kScale),
                 base, cv::FILLED, cv::LINE_AA, kShift);
      const int id = 4 * item.vehicle + item.marker;
      cv::circle(ids, fixed(centre), static_cast<int>(radius * kScale), id, cv::FILLED, cv::LINE_8, kShift);
      disc_area[item.vehicle][item.marker] = static_cast<int>(std::max(1.0, kPi * radius * radius));
    }
    for (size_t v = 0; v < vehicles.size(); ++v) {
      for (int k = 0; k < 4; ++k) {
        MarkerTruth& t = truth[v][c][k];
        if (!t.in_image) continue;
        const int reach = static_cast<int>(std::sqrt(disc_area[v][k] / kPi)) + 3;
        const cv::Rect around = cv::Rect(static_cast<int>(t.pixel.x) - reach, static_cast<int>(t.pixel.y) - reach,
                                         2 * reach + 1, 2 * reach + 1) & cv::Rect(0, 0, cam.size.width, cam.size.height);
        const cv::Mat own = ids(around) == static_cast<short>(4 * v + k);
        t.visible = std::min(1.0, cv::countNonZero(own) / static_cast<double>(disc_area[v][k]));
      }
    }
    cv::GaussianBlur(image, image, cv::Size(3, 3), 0.6);  // lens and sensor blur
    images.push_back(light(image, gain, static_cast<int>(c), 3.0, rng));
  }
  return images;
}

std::vector<FrameTruth> write_scene_set(const std::string& dir, const std::vector<SceneCamera>& cameras,
                                        const VehicleModel& model, const SceneOptions& options) {
  make_dir(dir);
  cv::RNG rng(options.seed);
  std::ofstream frames(dir + "/frames.csv"), truth_csv(dir + "/truth.csv"), markers_csv(dir + "/markers.csv");
  frames << "time_us";
  for (size_t c = 0; c < cameras.size(); ++c) frames << ",camera_" << c;
  frames << "\n";
  truth_csv << "time_us,id,north,east,down,qw,qx,qy,qz\n";
  markers_csv << "time_us,id,camera,colour,u,v,visible\n";
  std::vector<FrameTruth> out;
  for (int i = 0; i < options.frames; ++i) {
    FrameTruth ft;
    const double t = i / options.rate_hz;
    ft.time_us = static_cast<int64_t>(std::llround(t * 1e6)) + 1'000'000;
    ft.vehicles = scenario_states(options.scenario, t, cameras);
    const double mid = 0.5 * (options.min_gain + options.max_gain), amp = 0.5 * (options.max_gain - options.min_gain);
    const double gain = mid + amp * std::sin(2 * kPi * t / 1.7);
    const std::vector<cv::Mat> images = render_frame_set(cameras, model, ft.vehicles, gain, rng, ft.markers);
    frames << ft.time_us;
    for (size_t c = 0; c < images.size(); ++c) {
      char name[64];
      std::snprintf(name, sizeof name, "f%04d_cam%zu.png", i, c);
      write_png(dir + "/" + name, images[c]);
      frames << "," << name;
    }
    frames << "\n";
    for (size_t v = 0; v < ft.vehicles.size(); ++v) {
      const VehicleState& s = ft.vehicles[v];
      const cv::Vec4d q = quaternion_of(s.R_IB);
      truth_csv << ft.time_us << "," << s.id << "," << s.ned[0] << "," << s.ned[1] << "," << s.ned[2] << "," << q[0]
                << "," << q[1] << "," << q[2] << "," << q[3] << "\n";
      for (size_t c = 0; c < cameras.size(); ++c) {
        for (int k = 0; k < 4; ++k) {
          const MarkerTruth& m = ft.markers[v][c][k];
          markers_csv << ft.time_us << "," << s.id << "," << c << "," << k << "," << m.pixel.x << "," << m.pixel.y << ","
                      << (m.in_image ? m.visible : 0.0) << "\n";
        }
      }
    }
    out.push_back(ft);
  }
  // The tracker's configuration: the marker layout and where each vehicle starts.
  cv::FileStorage fs(dir + "/vehicles.yaml", cv::FileStorage::WRITE);
  const char* names[4] = {"marker_red", "marker_green", "marker_blue", "marker_yellow"};
  for (int k = 0; k < 4; ++k) fs << names[k] << "[:" << model.markers[k][0] << model.markers[k][1] << model.markers[k][2] << "]";
  fs << "vehicles" << "[";
  for (const VehicleState& s : out.front().vehicles) {
    fs << "{" << "id" << s.id << "ned" << "[:" << s.ned[0] << s.ned[1] << s.ned[2] << "]"
       << "yaw_deg" << std::atan2(s.R_IB(1, 0), s.R_IB(0, 0)) * 180.0 / kPi << "}";
  }
  fs << "]";
  return out;
}

}  // namespace ground_eval
