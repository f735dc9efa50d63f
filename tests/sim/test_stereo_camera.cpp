// The rendered stereo cameras against the vision station that consumes them: the station,
// calibrated with the rig the views are rendered through, must find the star where the truth says, from
// many heights and attitudes. Also the camera poses' geometry against the MJCF and the eq. 7.22 mount.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/calib3d.hpp>

#include "quad/sim/frames.h"
#include "quad/sim/stereo_camera.h"
#include "quad/sim/vehicle.h"
#include "quad/sim/vision_fix.h"
#include "quad/vision/stereo_calibration.h"
#include "quad/vision/stereo_locator.h"

namespace quad::sim {
namespace {

namespace vis = quad::vision;

Eigen::Quaterniond attitude(double roll, double pitch, double yaw) {
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
}

TEST(StereoCamera, LeftCameraSitsAtTheMountAndLooksDown) {
  // Level vehicle 1.5 m above the origin: the left camera is t_BC = (0.057, −0.057, 0.055) m from the
  // centre of mass in FRD, looks down (optical axis = NED down), image right = east, image down = south.
  const CameraPose pose = left_camera_pose(vis::thesis_camera_mount(), Eigen::Vector3d(0, 0, -1.5), attitude(0, 0, 0));
  const Eigen::Vector3d centre = -pose.R.transpose() * pose.t;
  EXPECT_NEAR((centre - Eigen::Vector3d(0.057, -0.057, -1.5 + 0.055)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((pose.R.row(2).transpose() - Eigen::Vector3d(0, 0, 1)).norm(), 0.0, 1e-12);   // z: down
  EXPECT_NEAR((pose.R.row(0).transpose() - Eigen::Vector3d(0, 1, 0)).norm(), 0.0, 1e-12);   // x: east
  EXPECT_NEAR((pose.R.row(1).transpose() - Eigen::Vector3d(-1, 0, 0)).norm(), 0.0, 1e-12);  // y: south
}

TEST(StereoCamera, MjcfCamerasMatchTheThesisMount) {
  // The MJCF's cam_left / cam_right (MuJoCo camera: looks along −z, y up) at the eq. 7.22 mount.
  VehicleParams params;
  params.model_path = QUAD_SIM_SOURCE_DIR "/models/quad_c.xml";
  Vehicle vehicle(params);
  vehicle.reset(Eigen::Vector2d::Zero(), 1.0, 0.0);
  const mjModel* m = vehicle.model();
  const vis::CameraMount mount = vis::thesis_camera_mount();
  for (const char* name : {"cam_left", "cam_right"}) {
    const int id = mj_name2id(m, mjOBJ_CAMERA, name);
    ASSERT_GE(id, 0) << name;
    // Camera position in the body (FLU) to FRD.
    const Eigen::Vector3d pos_frd(m->cam_pos[3 * id], -m->cam_pos[3 * id + 1], -m->cam_pos[3 * id + 2]);
    const double lateral = std::string(name) == "cam_left" ? mount.t_BC[1] : mount.t_BC[1] + vis::kThesisBaseline;
    EXPECT_NEAR(pos_frd.x(), mount.t_BC[0], 1e-9) << name;
    EXPECT_NEAR(pos_frd.y(), lateral, 1e-9) << name;
    EXPECT_NEAR(pos_frd.z(), mount.t_BC[2], 1e-9) << name;
  }
}

TEST(StereoCamera, ProjectionAgreesWithOpenCv) {
  const vis::StereoRig rig = vis::thesis_stereo_rig();
  const double valid = fold_radius(rig.left);
  EXPECT_NEAR(valid, 1.11, 0.01);  // docs/vision_station.md
  cv::RNG rng(3);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d p(rng.uniform(-0.8, 0.8), rng.uniform(-0.6, 0.6), rng.uniform(1.0, 2.0));
    const auto ours = project_point(rig.left, valid, p);
    ASSERT_TRUE(ours);
    std::vector<cv::Point2d> theirs;
    cv::projectPoints(std::vector<cv::Point3d>{{p.x(), p.y(), p.z()}}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                      cv::Mat(rig.left.K), cv::Mat(rig.left.D), theirs);
    EXPECT_NEAR(ours->x, theirs[0].x, 1e-6);
    EXPECT_NEAR(ours->y, theirs[0].y, 1e-6);
  }
  EXPECT_FALSE(project_point(rig.left, valid, Eigen::Vector3d(0.1, 0.1, -1.0)));
}

TEST(StereoCamera, StationFindsTheRenderedStarWhereTheTruthIs) {
  CameraParams params;
  params.enabled = true;
  StereoCameraRenderer renderer(params, make_floor_scene(params, Rng(5, "floor")), Rng(5, "camera"));
  const vis::StereoCalibration calibration = vis::rectify(renderer.rig());
  vis::LocatorSettings settings;
  settings.track_roi = false;
  vis::StereoStarLocator locator(calibration, settings);
  const vis::CameraMount mount = vis::thesis_camera_mount();
  Rng rng(9, "poses");
  int found = 0, trials = 0;
  double worst_relative = 0.0;
  cv::Mat left, right;
  for (double height = 0.6; height <= 2.51; height += 0.1) {
    for (int k = 0; k < 3; ++k, ++trials) {
      const Eigen::Vector3d p(rng.uniform(-0.15, 0.15), rng.uniform(-0.15, 0.15), -height);
      const Eigen::Quaterniond q = attitude(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), rng.uniform(-3.1, 3.1));
      renderer.render(p, q, false, left, right);
      ASSERT_EQ(left.size(), cv::Size(728, 488));
      const vis::StarFix fix = locator.locate(left, right);
      if (!fix.found) continue;
      ++found;
      const cv::Vec3d b = vis::camera_to_body(mount, fix.p_left);
      const Eigen::Vector3d truth = star_in_body_frd(p, q);
      const double error = (Eigen::Vector3d(b[0], b[1], b[2]) - truth).norm();
      worst_relative = std::max(worst_relative, error / truth.norm());
    }
  }
  EXPECT_GE(found, trials - 1) << "of " << trials;
  EXPECT_LT(worst_relative, 0.02);
}

TEST(StereoCamera, HiddenStarIsNotFound) {
  CameraParams params;
  StereoCameraRenderer renderer(params, make_floor_scene(params, Rng(5, "floor")), Rng(5, "camera"));
  vis::StereoStarLocator locator(vis::rectify(renderer.rig()), vis::LocatorSettings{});
  cv::Mat left, right;
  renderer.render(Eigen::Vector3d(0, 0, -1.5), attitude(0, 0, 0), false, left, right);
  EXPECT_TRUE(locator.locate(left, right).found);
  renderer.render(Eigen::Vector3d(0, 0, -1.5), attitude(0, 0, 0), true, left, right);
  EXPECT_FALSE(locator.locate(left, right).found);
}

TEST(StereoCamera, SameSeedSameImages) {
  CameraParams params;
  StereoCameraRenderer a(params, make_floor_scene(params, Rng(7, "floor")), Rng(7, "camera"));
  StereoCameraRenderer b(params, make_floor_scene(params, Rng(7, "floor")), Rng(7, "camera"));
  cv::Mat la, ra, lb, rb;
  for (int i = 0; i < 3; ++i) {
    a.render(Eigen::Vector3d(0.1, 0, -1.2), attitude(0.05, 0, 0.3), false, la, ra);
    b.render(Eigen::Vector3d(0.1, 0, -1.2), attitude(0.05, 0, 0.3), false, lb, rb);
    EXPECT_EQ(cv::norm(la, lb, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(ra, rb, cv::NORM_INF), 0.0);
  }
  // Noise and exposure make consecutive frames differ.
  a.render(Eigen::Vector3d(0.1, 0, -1.2), attitude(0.05, 0, 0.3), false, lb, rb);
  EXPECT_GT(cv::norm(la, lb, cv::NORM_INF), 0.0);
}

TEST(StereoCamera, FloorSceneShapesDoNotTouch) {
  CameraParams params;
  params.distractors = 12;
  const std::vector<FloorShape> scene = make_floor_scene(params, Rng(11, "floor"));
  ASSERT_EQ(scene.size(), 13u);
  EXPECT_NEAR(scene[0].outline[0].norm(), 0.20, 1e-12);  // star tip, 0.40 m tip to tip
  for (size_t i = 1; i < scene.size(); ++i) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& v : scene[i].outline) c += v;
    c /= static_cast<double>(scene[i].outline.size());
    EXPECT_GT(c.norm(), 0.45);
  }
}

}  // namespace
}  // namespace quad::sim
