// The star far off the axis of a wide lens: its image is sheared and stretched, and the polygon of its
// outline may put a vertex on a long tip's flank. The pose fit then takes the vertices from the outline's
// radius (StarPose::*_vertices_by_radius), and the fix stays within 2 % of the range.
#include <cmath>
#include <cstdio>
#include <optional>

#include <gtest/gtest.h>

#include "quad/vision/stereo_locator.h"
#include "star_scenes.h"

namespace quad::vision {
namespace {

// An analog FPV head: 720 × 480, fx ≈ 450 px, strong barrel distortion (image corners 54° off the axis).
StereoRig wide_fpv_rig() {
  StereoRig rig;
  rig.image_size = cv::Size(720, 480);
  rig.left = CameraIntrinsics{cv::Matx33d(452.0, 0.0, 362.5, 0.0, 447.0, 236.0, 0.0, 0.0, 1.0),
                              cv::Vec<double, 5>(-0.32, 0.12, 0.0005, -0.0003, -0.02)};
  rig.right = CameraIntrinsics{cv::Matx33d(446.0, 0.0, 355.0, 0.0, 442.5, 243.5, 0.0, 0.0, 1.0),
                               cv::Vec<double, 5>(-0.30, 0.10, -0.0004, 0.0006, -0.015)};
  rig.R = cv::Matx33d::eye();
  rig.T = cv::Vec3d(-0.12, 0.0, 0.0);
  return rig;
}

constexpr int kScenes = 12;

double off_axis(const cv::Vec3d& p) { return std::acos(p[2] / cv::norm(p)); }

// The star's centre on a ray 44–50° off the left camera's axis, the camera 1.8–2.6 m above the floor and
// tilted up to 20°; the whole star inside both views.
std::optional<testing::StarScene> far_off_axis_scene(const StereoRig& rig, cv::RNG& rng) {
  const std::vector<cv::Point2d> star = star_vertices(StarShape{});
  for (int attempt = 0; attempt < 500; ++attempt) {
    testing::StarScene scene;
    scene.height = rng.uniform(1.8, 2.6);
    scene.tilt = rng.uniform(0.0, 20.0 * CV_PI / 180.0);
    const double angle = rng.uniform(44.0, 50.0) * CV_PI / 180.0, direction = rng.uniform(0.0, 2.0 * CV_PI);
    const cv::Point2d ray = std::tan(angle) * cv::Point2d(std::cos(direction), std::sin(direction));
    scene.left_pose = testing::camera_pose(scene.height, scene.tilt, rng.uniform(0.0, 2.0 * CV_PI),
                                           rng.uniform(0.0, CV_PI / 2.0), ray, cv::Point2d(0, 0));
    const testing::Pose right = testing::right_pose(rig, scene.left_pose);
    if (!testing::fully_visible(rig.left, rig.image_size, scene.left_pose, star, 4.0) ||
        !testing::fully_visible(rig.right, rig.image_size, right, star, 4.0)) {
      continue;
    }
    testing::RenderOptions options;
    options.floor_grey = rng.uniform(150.0, 235.0);
    const std::vector<testing::FloorShape> shapes{testing::FloorShape{star, rng.uniform(20.0, 80.0)}};
    const auto left = testing::render_view(rig.left, rig.image_size, scene.left_pose, shapes, options, rng);
    const auto right_image = testing::render_view(rig.right, rig.image_size, right, shapes, options, rng);
    if (!left || !right_image) continue;
    scene.left = *left;
    scene.right = *right_image;
    scene.truth_left = scene.left_pose.t;  // the floor origin is the star centre
    return scene;
  }
  return std::nullopt;
}

TEST(StarPoseOffAxisTest, StarsBeyond44DegreesAreFoundWithinTwoPercent) {
  const StereoRig rig = wide_fpv_rig();
  const StereoCalibration calibration = rectify(rig);
  cv::RNG rng(2024);
  int found = 0, by_radius = 0;
  for (int i = 0; i < kScenes; ++i) {
    const auto scene = far_off_axis_scene(rig, rng);
    ASSERT_TRUE(scene) << "no star fully in view 44–50° off the axis";
    ASSERT_GT(off_axis(scene->truth_left), 44.0 * CV_PI / 180.0);
    StereoStarLocator locator(calibration, LocatorSettings{});
    const StarFix fix = locator.locate(scene->left, scene->right);
    const double range = cv::norm(scene->truth_left);
    if (fix.found && cv::norm(fix.p_left - scene->truth_left) < 0.02 * range) ++found;
    if (fix.pose.left_vertices_by_radius || fix.pose.right_vertices_by_radius) ++by_radius;
  }
  std::printf("%d scenes 44–50° off the axis: %d found within 2 %%, %d with the radius method's vertices\n", kScenes,
              found, by_radius);
  EXPECT_EQ(found, kScenes);
  // The fallback ran: some of these stars had no polygon fit within StarPoseSettings::max_rms_px.
  EXPECT_GE(by_radius, 1);
}

}  // namespace
}  // namespace quad::vision
