#include "quad/sim/ground_camera.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace quad::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kFloorRadiusM = 6.0;   // the room: floor within this distance of the centre, then walls
constexpr double kTileM = 0.5;
constexpr int kNoiseBank = 4, kNoiseShiftRows = 64;
// Marker albedo (B, G, R): saturated paints of the four colours.
const std::array<cv::Vec3f, kMarkerColourCount> kMarkerAlbedo{cv::Vec3f(50, 50, 235), cv::Vec3f(60, 205, 55),
                                                              cv::Vec3f(205, 85, 45), cv::Vec3f(40, 205, 225)};
const cv::Vec3f kFrameAlbedo(38, 38, 40);  // the dark hub and arms

// A light from above, a little to the north-east (NED, towards the light).
Eigen::Vector3d light_direction_ned() { return Eigen::Vector3d(0.3, 0.2, -1.0).normalized(); }

}  // namespace

const char* ground_fix_message_name(GroundFixMessage message) {
  switch (message) {
    case GroundFixMessage::kVisionPositionEstimate: return "vision_position_estimate";
  }
  return "?";
}

std::vector<GroundCamera> ground_cameras_from(const GroundCameraParams& p) {
  std::vector<GroundCamera> cameras;
  const double f = 0.5 * p.image_width / std::tan(0.5 * p.hfov_deg * kPi / 180.0);
  for (int k = 0; k < p.count; ++k) {
    GroundCamera c;
    c.width = p.image_width;
    c.height = p.image_height;
    // A real sensor's principal point is a few pixels off the centre, differently per camera.
    c.lens = LensParams{f, f, 0.5 * p.image_width + 3.0 - 2.0 * k, 0.5 * p.image_height - 2.0 + 1.5 * k,
                        p.distortion[0], p.distortion[1], p.distortion[2], p.distortion[3], p.distortion[4]};
    const double azimuth = (p.first_azimuth_deg + k * p.spacing_deg) * kPi / 180.0;
    const Eigen::Vector3d centre(p.centre_ne.x() + p.distance_m * std::cos(azimuth),
                                 p.centre_ne.y() + p.distance_m * std::sin(azimuth), -p.height_m);
    const Eigen::Vector3d aim(p.centre_ne.x(), p.centre_ne.y(), -p.aim_height_m);
    const Eigen::Vector3d z = (aim - centre).normalized();
    const Eigen::Vector3d x = z.cross(Eigen::Vector3d(0.0, 0.0, -1.0)).normalized();  // level: right is horizontal
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d R_IC;
    R_IC << x, y, z;
    c.R_CI = R_IC.transpose();
    c.t_CI = -c.R_CI * centre;
    cameras.push_back(c);
  }
  return cameras;
}

// A ball (marker) or a box (hub, arm) in one camera's frame.
struct GroundCameraRenderer::Primitive {
  bool box = false;
  Eigen::Vector3d centre;     // camera frame
  Eigen::Matrix3d axes;       // box: columns are its axes in the camera frame
  Eigen::Vector3d half;       // box: half extents; ball: radius in x
  cv::Vec3f albedo;
  int vehicle = -1, colour = -1;  // a marker's
  double reach = 0.0;             // radius of a sphere around `centre` holding the whole primitive
  cv::Rect bounds;

  // Whether the ray (x, y, 1) passes within `reach` + `slack` · depth of the centre (cheap pre-test).
  bool near(const Eigen::Vector3d& d, double slack) const {
    const double along = d.dot(centre) / d.squaredNorm();
    const double r = reach + slack * std::max(along, 0.0);
    return (along * d - centre).squaredNorm() <= r * r;
  }

  // Depth (camera z) where the ray (x, y, 1) enters, and the surface normal there; false on a miss.
  bool hit(const Eigen::Vector3d& d, double& depth, Eigen::Vector3d& normal) const {
    if (!box) {
      const double r = half.x();
      const double dd = d.dot(d), dc = d.dot(centre);
      const double disc = dc * dc - dd * (centre.dot(centre) - r * r);
      if (disc < 0.0) return false;
      depth = (dc - std::sqrt(disc)) / dd;
      if (depth <= 0.0) return false;
      normal = (depth * d - centre) / r;
      return true;
    }
    const Eigen::Vector3d o = axes.transpose() * (-centre), dir = axes.transpose() * d;
    double t0 = -std::numeric_limits<double>::infinity(), t1 = std::numeric_limits<double>::infinity();
    int face = 0;
    for (int i = 0; i < 3; ++i) {
      if (std::abs(dir(i)) < 1e-12) {
        if (std::abs(o(i)) > half(i)) return false;
        continue;
      }
      double a = (-half(i) - o(i)) / dir(i), b = (half(i) - o(i)) / dir(i);
      if (a > b) std::swap(a, b);
      if (a > t0) {
        t0 = a;
        face = i;
      }
      t1 = std::min(t1, b);
      if (t0 > t1) return false;
    }
    if (t0 <= 0.0) return false;
    depth = t0;
    Eigen::Vector3d n = Eigen::Vector3d::Zero();
    n(face) = dir(face) > 0.0 ? -1.0 : 1.0;
    normal = axes * n;
    return true;
  }
};

GroundCameraRenderer::GroundCameraRenderer(const GroundCameraParams& params, std::vector<GroundCamera> cameras, Rng rng)
    : p_(params), cameras_(std::move(cameras)), rng_(std::move(rng)) {
  for (double& phase : light_phase_) phase = rng_.uniform(0.0, 2.0 * kPi);
  for (const GroundCamera& c : cameras_) views_.push_back(make_view(c));
  const int w = p_.image_width, h = p_.image_height;
  for (int b = 0; b < kNoiseBank; ++b) {
    cv::Mat noise(h + kNoiseShiftRows, w, CV_16SC3);
    for (int v = 0; v < noise.rows; ++v) {
      int16_t* row = noise.ptr<int16_t>(v);
      for (int i = 0; i < 3 * w; ++i) row[i] = static_cast<int16_t>(std::lround(rng_.normal(p_.noise_grey)));
    }
    noise_bank_.push_back(noise);
  }
}

GroundCameraRenderer::View GroundCameraRenderer::make_view(const GroundCamera& camera) {
  View view;
  view.camera = camera;
  view.valid_radius = lens_fold_radius(camera.lens);
  const cv::Size size(camera.width, camera.height);
  view.rays.create(size, CV_32FC2);
  view.base.create(size, CV_32FC3);
  view.shading.create(size, CV_32FC3);
  view.done = cv::Mat::zeros(size, CV_8U);
  // The camera's colour cast, and the direction its brightness falls across the image.
  cv::Vec3f cast;
  for (int c = 0; c < 3; ++c) cast[c] = static_cast<float>(1.0 + rng_.uniform(-p_.white_balance, p_.white_balance));
  const double ramp_angle = rng_.uniform(0.0, 2.0 * kPi);
  const Eigen::Vector2d ramp_dir(std::cos(ramp_angle), std::sin(ramp_angle));
  const double half_diag = 0.5 * std::hypot(camera.width, camera.height);
  Rng tiles(7, "ground_floor_tiles");  // the floor's tile greys: the same room for every camera
  std::vector<float> tile_grey(64 * 64);
  for (float& g : tile_grey) g = static_cast<float>(118.0 + tiles.uniform(-10.0, 10.0));
  const Eigen::Matrix3d R_IC = camera.R_CI.transpose();
  const Eigen::Vector3d origin = camera.centre_ned();
  constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
  for (int v = 0; v < size.height; ++v) {
    cv::Vec2f* ray = view.rays.ptr<cv::Vec2f>(v);
    cv::Vec3f* base = view.base.ptr<cv::Vec3f>(v);
    cv::Vec3f* shade = view.shading.ptr<cv::Vec3f>(v);
    for (int u = 0; u < size.width; ++u) {
      const auto xy = unproject_lens(camera.lens, view.valid_radius, Eigen::Vector2d(u, v));
      ray[u] = xy ? cv::Vec2f(static_cast<float>(xy->x()), static_cast<float>(xy->y())) : cv::Vec2f(kNan, kNan);
      const double ramp = 1.0 - p_.light_ramp * (0.5 + 0.5 * ramp_dir.dot(Eigen::Vector2d(u - 0.5 * size.width, v - 0.5 * size.height)) / half_diag);
      for (int c = 0; c < 3; ++c) shade[u][c] = static_cast<float>(ramp * cast[c]);
      float grey = 150.0f;  // the walls
      if (xy) {
        const Eigen::Vector3d d = R_IC * Eigen::Vector3d(xy->x(), xy->y(), 1.0);
        if (d.z() > 1e-6) {
          const Eigen::Vector3d floor = origin + (-origin.z() / d.z()) * d;
          if (Eigen::Vector2d(floor.x() - p_.centre_ne.x(), floor.y() - p_.centre_ne.y()).norm() < kFloorRadiusM) {
            const int i = static_cast<int>(std::floor(floor.x() / kTileM)) & 63, j = static_cast<int>(std::floor(floor.y() / kTileM)) & 63;
            grey = tile_grey[static_cast<size_t>(i * 64 + j)];
          }
        }
      }
      for (int c = 0; c < 3; ++c) base[u][c] = grey * shade[u][c];
    }
  }
  return view;
}

double GroundCameraRenderer::light_gain(double t) const {
  // Two slow swings (periods 7 s and 19 s) with random phases: a room light dimming, a cloud passing.
  const double s = 0.6 * std::sin(2.0 * kPi * t / 7.0 + light_phase_[0]) + 0.4 * std::sin(2.0 * kPi * t / 19.0 + light_phase_[1]);
  return 0.5 * (p_.light_min + p_.light_max) + 0.5 * (p_.light_max - p_.light_min) * s;
}

std::vector<GroundCameraRenderer::Primitive> GroundCameraRenderer::primitives(const View& view,
                                                                             const std::vector<MarkedVehicle>& vehicles) const {
  std::vector<Primitive> out;
  const GroundCamera& cam = view.camera;
  // The image rectangle of the primitive: its bounding box's corners projected, with a margin.
  auto bound = [&](Primitive& p) {
    const Eigen::Vector3d half = p.box ? p.half : Eigen::Vector3d::Constant(p.half.x());
    const Eigen::Matrix3d axes = p.box ? p.axes : Eigen::Matrix3d::Identity();
    p.reach = half.norm();
    if (p.centre.z() - p.reach < 0.05) return false;
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (int corner = 0; corner < 8; ++corner) {
      const Eigen::Vector3d k((corner & 1) ? 1.0 : -1.0, (corner & 2) ? 1.0 : -1.0, (corner & 4) ? 1.0 : -1.0);
      const auto uv = project_lens(cam.lens, view.valid_radius, p.centre + axes * half.cwiseProduct(k));
      if (!uv) return false;
      x0 = std::min(x0, uv->x()); y0 = std::min(y0, uv->y()); x1 = std::max(x1, uv->x()); y1 = std::max(y1, uv->y());
    }
    p.bounds = cv::Rect(cv::Point(static_cast<int>(std::floor(x0)) - 2, static_cast<int>(std::floor(y0)) - 2),
                        cv::Point(static_cast<int>(std::ceil(x1)) + 3, static_cast<int>(std::ceil(y1)) + 3)) &
               cv::Rect(0, 0, cam.width, cam.height);
    return !p.bounds.empty();
  };
  for (size_t i = 0; i < vehicles.size(); ++i) {
    const MarkedVehicle& veh = vehicles[i];
    const Eigen::Matrix3d R_CB = cam.R_CI * veh.q_ib.toRotationMatrix();
    const Eigen::Vector3d body = cam.R_CI * veh.p_ned + cam.t_CI;
    for (int c = 0; c < kMarkerColourCount; ++c) {
      Primitive p;
      p.centre = body + R_CB * veh.markers_frd[static_cast<size_t>(c)];
      p.half = Eigen::Vector3d(veh.marker_radius_m, 0.0, 0.0);
      p.albedo = kMarkerAlbedo[static_cast<size_t>(c)];
      p.vehicle = static_cast<int>(i);
      p.colour = c;
      if (bound(p)) out.push_back(p);
    }
    // The hub (quad_c.xml: 0.16 × 0.16 × 0.09 m) and the four arms (0.26 m, 2.4 cm thick, 2 cm above the hub's centre).
    struct Part {
      Eigen::Vector3d centre, half;
    };
    const Part parts[] = {{{0.0, 0.0, 0.0}, {0.08, 0.08, 0.045}},   {{0.13, 0.0, -0.02}, {0.13, 0.012, 0.012}},
                          {{-0.13, 0.0, -0.02}, {0.13, 0.012, 0.012}}, {{0.0, 0.13, -0.02}, {0.012, 0.13, 0.012}},
                          {{0.0, -0.13, -0.02}, {0.012, 0.13, 0.012}}};
    for (const Part& part : parts) {
      Primitive p;
      p.box = true;
      p.centre = body + R_CB * part.centre;
      p.axes = R_CB;
      p.half = part.half;
      p.albedo = kFrameAlbedo;
      if (bound(p)) out.push_back(p);
    }
  }
  return out;
}

void GroundCameraRenderer::render(size_t camera, const std::vector<MarkedVehicle>& vehicles, double t, cv::Mat& bgr,
                                  MarkerViews* views) {
  View& view = views_.at(camera);
  const double gain = light_gain(t);
  cv::Mat image16;
  view.base.convertTo(image16, CV_16SC3, gain);
  const std::vector<Primitive> prims = primitives(view, vehicles);
  const Eigen::Vector3d light = view.camera.R_CI * light_direction_ned();
  std::vector<std::array<int, kMarkerColourCount>> seen(vehicles.size()), hits(vehicles.size());
  for (auto& s : seen) s.fill(0);
  for (auto& h : hits) h.fill(0);
  constexpr double kSub[2] = {-0.25, 0.25};
  std::vector<const Primitive*> here;
  const double pixel_angle = 1.5 / std::min(view.camera.lens.fx, view.camera.lens.fy);
  for (const Primitive& prim : prims) {
    for (int v = prim.bounds.y; v < prim.bounds.y + prim.bounds.height; ++v) {
      uint8_t* done = view.done.ptr<uint8_t>(v);
      const cv::Vec2f* ray = view.rays.ptr<cv::Vec2f>(v);
      const cv::Vec2f* ray_next = view.rays.ptr<cv::Vec2f>(std::min(v + 1, view.rays.rows - 1));
      for (int u = prim.bounds.x; u < prim.bounds.x + prim.bounds.width; ++u) {
        if (done[u]) continue;
        done[u] = 1;
        if (std::isnan(ray[u][0])) continue;
        // Only what the pixel's centre ray passes near (within about a pixel) can cover its samples.
        here.clear();
        const Eigen::Vector3d d0(ray[u][0], ray[u][1], 1.0);
        for (const Primitive& q : prims)
          if (q.bounds.contains(cv::Point(u, v)) && q.near(d0, pixel_angle)) here.push_back(&q);
        if (here.empty()) continue;
        const cv::Vec2f dx = ray[std::min(u + 1, view.rays.cols - 1)] - ray[u], dy = ray_next[u] - ray[u];
        cv::Vec3f sum(0, 0, 0);
        int covered = 0;
        for (double sy : kSub)
          for (double sx : kSub) {
            const Eigen::Vector3d d(ray[u][0] + sx * dx[0] + sy * dy[0], ray[u][1] + sx * dx[1] + sy * dy[1], 1.0);
            const Primitive* front = nullptr;
            double best = std::numeric_limits<double>::infinity();
            Eigen::Vector3d best_normal;
            for (const Primitive* q : here) {
              double depth;
              Eigen::Vector3d normal;
              if (!q->hit(d, depth, normal)) continue;
              if (q->colour >= 0) ++hits[static_cast<size_t>(q->vehicle)][static_cast<size_t>(q->colour)];
              if (depth < best) {
                best = depth;
                front = q;
                best_normal = normal;
              }
            }
            if (!front) continue;
            if (front->colour >= 0) ++seen[static_cast<size_t>(front->vehicle)][static_cast<size_t>(front->colour)];
            const double shade = 0.55 + 0.45 * std::max(0.0, best_normal.dot(light));
            sum += front->albedo * static_cast<float>(shade);
            ++covered;
          }
        if (covered == 0) continue;
        const cv::Vec3f s = view.shading.at<cv::Vec3f>(v, u);
        cv::Vec3s& px = image16.at<cv::Vec3s>(v, u);
        for (int c = 0; c < 3; ++c) {
          const double drawn = gain * s[c] * sum[c];
          const double background = px[c];
          px[c] = static_cast<int16_t>(std::lround((drawn + (4 - covered) * background) / 4.0));
        }
      }
    }
  }
  for (const Primitive& prim : prims) view.done(prim.bounds).setTo(0);
  add_noise(image16);
  image16.convertTo(bgr, CV_8UC3);
  if (!views) return;
  views->assign(vehicles.size(), {});
  for (size_t i = 0; i < vehicles.size(); ++i) {
    const MarkedVehicle& veh = vehicles[i];
    const GroundCamera& cam = view.camera;
    for (int c = 0; c < kMarkerColourCount; ++c) {
      MarkerView& mv = (*views)[i][static_cast<size_t>(c)];
      const Eigen::Vector3d p = cam.R_CI * (veh.p_ned + veh.q_ib * veh.markers_frd[static_cast<size_t>(c)]) + cam.t_CI;
      const auto uv = project_lens(cam.lens, view.valid_radius, p);
      if (!uv) continue;
      mv.pixel = *uv;
      mv.radius_px = cam.lens.fx * veh.marker_radius_m / p.z();
      const int h = hits[i][static_cast<size_t>(c)];
      mv.visible = h > 0 ? static_cast<double>(seen[i][static_cast<size_t>(c)]) / h : 0.0;
    }
  }
}

void GroundCameraRenderer::render_target(size_t camera, const CameraPose& target, const std::vector<FloorShape>& shapes,
                                         cv::Mat& bgr) {
  View& view = views_.at(camera);
  // The target's greys over the room's (its brightness without the ramp and cast), then ramp and cast.
  cv::Mat albedo;
  {
    std::vector<cv::Mat> channels;
    cv::Mat unshaded;
    cv::divide(view.base, view.shading, unshaded);
    cv::split(unshaded, channels);
    albedo = (channels[0] + channels[1] + channels[2]) / 3.0;
  }
  paint_shapes(view.camera.lens, view.valid_radius, target, shapes, 0, albedo, crossings_, coverage_);
  cv::Mat grey3, image;
  cv::merge(std::vector<cv::Mat>{albedo, albedo, albedo}, grey3);
  cv::multiply(grey3, view.shading, image);
  cv::Mat image16;
  image.convertTo(image16, CV_16SC3);
  add_noise(image16);
  image16.convertTo(bgr, CV_8UC3);
}

void GroundCameraRenderer::add_noise(cv::Mat& image16) {
  if (p_.noise_grey <= 0.0) return;
  const cv::Mat& bank = noise_bank_[static_cast<size_t>(rng_.uniform(0.0, kNoiseBank - 1e-9))];
  const int shift = static_cast<int>(rng_.uniform(0.0, kNoiseShiftRows - 1e-9));
  cv::add(image16, bank.rowRange(shift, shift + image16.rows), image16);
}

}  // namespace quad::sim
