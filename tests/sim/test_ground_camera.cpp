// The simulator's room cameras (quad/sim/ground_camera.h): where they stand (seed 003 table 6.1), the
// balls drawn where OpenCV's own projection puts them (cv::projectPoints with the cameras' lens and pose,
// an implementation apart from the simulator's), balls hidden behind another vehicle's hub, the light's
// range; and the scenario's ground_cameras keys.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/sim/ground_camera.h"
#include "quad/sim/scenario.h"

namespace quad::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string error_of(const std::string& yaml) {
  try {
    parse_scenario(yaml, "bad.yaml", ".");
  } catch (const ScenarioError& e) {
    return e.what();
  }
  return "(no error)";
}

// OpenCV's projection of a room point through camera c.
cv::Point2d opencv_pixel(const GroundCamera& c, const Eigen::Vector3d& p_ned) {
  const cv::Matx33d K(c.lens.fx, 0, c.lens.cx, 0, c.lens.fy, c.lens.cy, 0, 0, 1);
  const std::vector<double> D{c.lens.k1, c.lens.k2, c.lens.p1, c.lens.p2, c.lens.k3};
  cv::Matx33d R;
  for (int i = 0; i < 9; ++i) R(i / 3, i % 3) = c.R_CI(i / 3, i % 3);
  cv::Vec3d rvec;
  cv::Rodrigues(R, rvec);
  std::vector<cv::Point2d> out;
  cv::projectPoints(std::vector<cv::Point3d>{{p_ned.x(), p_ned.y(), p_ned.z()}}, rvec, cv::Vec3d(c.t_CI.x(), c.t_CI.y(), c.t_CI.z()),
                    K, D, out);
  return out[0];
}

// The centroid of the pixels of one colour (a plain test of its own: that channel well above the
// others) within `radius` of `near`, and their count.
cv::Point2d blob_centroid(const cv::Mat& bgr, int colour, cv::Point2d near, double radius, int& count) {
  double su = 0, sv = 0;
  count = 0;
  for (int v = std::max(0, static_cast<int>(near.y - radius)); v < std::min(bgr.rows, static_cast<int>(near.y + radius)); ++v)
    for (int u = std::max(0, static_cast<int>(near.x - radius)); u < std::min(bgr.cols, static_cast<int>(near.x + radius)); ++u) {
      const cv::Vec3b p = bgr.at<cv::Vec3b>(v, u);
      const int b = p[0], g = p[1], r = p[2];
      const bool hit = colour == 0 ? r > 2 * g && r > 2 * b
                     : colour == 1 ? g > 2 * r && g > 2 * b
                     : colour == 2 ? b > 2 * r && b > 2 * g
                                   : r > 2 * b && g > 2 * b && std::abs(r - g) < 60;
      if (!hit) continue;
      su += u;
      sv += v;
      ++count;
    }
  return count ? cv::Point2d(su / count, sv / count) : cv::Point2d(-1, -1);
}

// One renderer for the tests (its construction traces a ray per pixel of both cameras).
const GroundCameraParams& test_params() {
  static const GroundCameraParams p = [] {
    GroundCameraParams q;
    q.light_min = 0.6;
    q.light_max = 1.1;
    return q;
  }();
  return p;
}
GroundCameraRenderer& test_renderer() {
  static GroundCameraRenderer renderer(test_params(), ground_cameras_from(test_params()), Rng(3, "test"));
  return renderer;
}

MarkedVehicle vehicle_at(const GroundCameraParams& p, int id, const Eigen::Vector3d& ned, double yaw) {
  MarkedVehicle v;
  v.id = id;
  v.p_ned = ned;
  v.q_ib = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  v.markers_frd = p.markers_frd;
  v.marker_radius_m = p.marker_radius_m;
  return v;
}

TEST(GroundCamera, TheRigOfSeed003Table61) {
  const GroundCameraParams p;
  const std::vector<GroundCamera> cams = ground_cameras_from(p);
  ASSERT_EQ(cams.size(), 2u);
  for (const GroundCamera& c : cams) {
    EXPECT_EQ(c.width, 1024);
    EXPECT_EQ(c.height, 768);
    EXPECT_NEAR(2.0 * std::atan(0.5 * c.width / c.lens.fx) * 180.0 / kPi, 56.1, 1e-9);
    EXPECT_NEAR(-c.centre_ned().z(), 1.40, 1e-12);
    EXPECT_NEAR(c.centre_ned().head<2>().norm(), 2.20, 1e-12);
    // The optical axis passes over the centre, the image's x axis level.
    const Eigen::Vector3d axis = c.R_CI.transpose().col(2), right = c.R_CI.transpose().col(0);
    const Eigen::Vector3d to_aim = Eigen::Vector3d(0, 0, -p.aim_height_m) - c.centre_ned();
    EXPECT_NEAR(axis.dot(to_aim.normalized()), 1.0, 1e-12);
    EXPECT_NEAR(right.z(), 0.0, 1e-12);
  }
  // 90 degrees apart: camera 0 south of the centre, camera 1 west.
  EXPECT_NEAR(cams[0].centre_ned().x(), -2.20, 1e-12);
  EXPECT_NEAR(cams[1].centre_ned().y(), -2.20, 1e-12);
}

TEST(GroundCamera, BallsAreDrawnWhereOpenCvProjectsThem) {
  const GroundCameraParams& p = test_params();
  GroundCameraRenderer& renderer = test_renderer();
  const MarkedVehicle v = vehicle_at(p, 1, Eigen::Vector3d(0.1, -0.2, -1.0), 0.4);
  cv::Mat image;
  MarkerViews views;
  for (size_t k = 0; k < renderer.cameras().size(); ++k) {
    renderer.render(k, {v}, 1.0, image, &views);
    ASSERT_EQ(image.type(), CV_8UC3);
    for (int c = 0; c < kMarkerColourCount; ++c) {
      const Eigen::Vector3d centre = v.p_ned + v.q_ib * v.markers_frd[static_cast<size_t>(c)];
      const cv::Point2d expected = opencv_pixel(renderer.cameras()[k], centre);
      const MarkerView& mv = views[0][static_cast<size_t>(c)];
      EXPECT_NEAR(mv.pixel.x(), expected.x, 1e-6);
      EXPECT_NEAR(mv.pixel.y(), expected.y, 1e-6);
      int count = 0;
      const cv::Point2d found = blob_centroid(image, c, expected, 3.0 * mv.radius_px + 4.0, count);
      if (mv.visible < 0.9) continue;  // partly behind the hub or an arm from this camera
      // About pi r^2 pixels, centred on the projection (a sphere's image centre is within a fraction of
      // a pixel of its centre's projection at this distance; the shading from above moves it slightly).
      EXPECT_NEAR(count, kPi * mv.radius_px * mv.radius_px, 0.35 * kPi * mv.radius_px * mv.radius_px) << "camera " << k << " colour " << c;
      EXPECT_LT(cv::norm(found - expected), 0.6) << "camera " << k << " colour " << c;
    }
  }
}

TEST(GroundCamera, AVehicleInFrontHidesTheBallsBehindIt) {
  const GroundCameraParams& p = test_params();
  GroundCameraRenderer& renderer = test_renderer();
  const GroundCamera& cam = renderer.cameras()[0];
  const MarkedVehicle far = vehicle_at(p, 1, Eigen::Vector3d(0.3, 0.0, -1.0), 0.0);
  // A second vehicle on the line from camera 0 to the far vehicle's red ball, its hub on that line.
  const Eigen::Vector3d red = far.p_ned + far.markers_frd[0];
  const Eigen::Vector3d between = cam.centre_ned() + 0.6 * (red - cam.centre_ned());
  const MarkedVehicle near = vehicle_at(p, 2, between, 0.0);
  cv::Mat image;
  MarkerViews views;
  renderer.render(0, {far}, 0.0, image, &views);
  EXPECT_GT(views[0][0].visible, 0.9);  // its own arm may cover an edge
  renderer.render(0, {far, near}, 0.0, image, &views);
  EXPECT_LT(views[0][0].visible, 0.01);
  int count = 0;
  blob_centroid(image, 0, cv::Point2d(views[0][0].pixel.x(), views[0][0].pixel.y()), views[0][0].radius_px, count);
  EXPECT_EQ(count, 0);
}

TEST(GroundCamera, TheLightStaysInItsRange) {
  const GroundCameraRenderer& renderer = test_renderer();
  double lo = 10, hi = 0;
  for (double t = 0; t < 60.0; t += 0.05) {
    lo = std::min(lo, renderer.light_gain(t));
    hi = std::max(hi, renderer.light_gain(t));
  }
  EXPECT_GE(lo, 0.6);
  EXPECT_LE(hi, 1.1);
  EXPECT_GT(hi - lo, 0.3);  // it does wander
}

TEST(GroundCamera, ScenarioKeys) {
  const Scenario s = parse_scenario(
      "name: g\nduration_s: 5\nvision: {enabled: false}\n"
      "ground_cameras: {enabled: true, count: 3, rate_hz: 25, trigger: free, phase_s: [0, 0.01, 0.02], latency_s: 0.05,\n"
      "                 markers_frd_m: {yellow: [0, -0.2, -0.12]}, light: {min: 0.5, max: 1.0}}\n",
      "g.yaml", ".");
  EXPECT_TRUE(s.ground_cameras.enabled);
  EXPECT_EQ(s.ground_cameras.count, 3);
  EXPECT_FALSE(s.ground_cameras.triggered);
  ASSERT_EQ(s.ground_cameras.phase_s.size(), 3u);
  EXPECT_DOUBLE_EQ(s.ground_cameras.phase_s[2], 0.02);
  EXPECT_DOUBLE_EQ(s.ground_cameras.markers_frd[3].z(), -0.12);
  EXPECT_DOUBLE_EQ(s.ground_cameras.markers_frd[0].x(), 0.20);  // the default red
  EXPECT_NE(error_of("name: g\nduration_s: 5\nground_cameras: {trigger: sometimes}\n").find("bad.yaml:3: 'ground_cameras.trigger' must be together or free"),
            std::string::npos);
  EXPECT_NE(error_of("name: g\nduration_s: 5\nground_cameras: {phase_s: [0, 0.01]}\n").find("needs trigger: free"), std::string::npos);
  EXPECT_NE(error_of("name: g\nduration_s: 5\nground_cameras: {trigger: free, phase_s: [0, 0.05]}\n").find("'ground_cameras.phase_s[1]' must be in"),
            std::string::npos);
  EXPECT_NE(error_of("name: g\nduration_s: 5\nground_cameras: {message: att_pos_mocap}\n").find("must be vision_position_estimate"),
            std::string::npos);
  EXPECT_NE(error_of("name: g\nduration_s: 5\ncamera: {enabled: true}\nground_cameras: {enabled: true}\n").find("exclude each other"),
            std::string::npos);
  EXPECT_NE(error_of("name: g\nduration_s: 5\nground_cameras: {lenses: 2}\n").find("'ground_cameras.lenses' is not a known key"),
            std::string::npos);
}

}  // namespace
}  // namespace quad::sim
