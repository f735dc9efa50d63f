// The simulator's own camera model against independent references: its projection against
// cv::projectPoints, its mounts against the MJCF and the thesis' eq. 7.22, its floor photograph against
// a ray-plane intersection through cv::undistortPoints, and its capture effects (interlaced fields,
// motion blur, JPEG) against renders at the instants they stand for.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/sim/camera_model.h"
#include "quad/sim/stereo_camera.h"
#include "quad/sim/vehicle.h"

namespace quad::sim {
namespace {

cv::Matx33d camera_matrix(const LensParams& l) { return {l.fx, 0.0, l.cx, 0.0, l.fy, l.cy, 0.0, 0.0, 1.0}; }
cv::Vec<double, 5> distortion(const LensParams& l) { return {l.k1, l.k2, l.p1, l.p2, l.k3}; }

SimStereoRig shipped_rig(const CameraParams& params) {
  VehicleParams vp;
  vp.model_path = QUAD_SIM_SOURCE_DIR "/models/quad_c.xml";
  Vehicle vehicle(vp);
  return stereo_rig_from_model(vehicle.model(), params, vp.model_path);
}

// Clean images: no noise, wander or vignetting, so that renders can be compared pixel by pixel.
CameraParams clean_params() {
  CameraParams p;
  p.noise_grey = 0.0;
  p.exposure_variation = 0.0;
  p.vignetting = 0.0;
  return p;
}

TEST(CameraModel, ProjectionAgreesWithOpenCv) {
  LensParams tangential = CameraParams().left;
  tangential.p1 = 0.002;
  tangential.p2 = -0.003;
  for (const LensParams& lens : {CameraParams().left, CameraParams().right, tangential}) {
    const double valid = lens_fold_radius(lens);
    cv::RNG rng(3);
    for (int i = 0; i < 300; ++i) {
      // Inside the lens' monotonic part (normalised radius < 0.9 of the fold).
      const double z = rng.uniform(0.5, 3.0), r = rng.uniform(0.0, 0.9 * valid), a = rng.uniform(0.0, 2.0 * CV_PI);
      const Eigen::Vector3d p(z * r * std::cos(a), z * r * std::sin(a), z);
      const auto ours = project_lens(lens, valid, p);
      ASSERT_TRUE(ours);
      std::vector<cv::Point2d> theirs;
      cv::projectPoints(std::vector<cv::Point3d>{{p.x(), p.y(), p.z()}}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                        cv::Mat(camera_matrix(lens)), cv::Mat(distortion(lens)), theirs);
      EXPECT_NEAR(ours->x(), theirs[0].x, 1e-6);
      EXPECT_NEAR(ours->y(), theirs[0].y, 1e-6);
      const auto back = unproject_lens(lens, valid, *ours);
      ASSERT_TRUE(back);
      EXPECT_NEAR(back->x(), p.x() / p.z(), 1e-7);
      EXPECT_NEAR(back->y(), p.y() / p.z(), 1e-7);
    }
    EXPECT_FALSE(project_lens(lens, valid, Eigen::Vector3d(0.1, 0.1, -1.0)));
  }
  EXPECT_NEAR(lens_fold_radius(CameraParams().left), 1.11, 0.01);
}

TEST(CameraModel, MountsComeFromTheMjcfAtTheThesisPose) {
  const SimStereoRig rig = shipped_rig(CameraParams());
  // Eq. 7.22: camera x along body y, camera y along body −x, optical axis along body z (down).
  const Eigen::Matrix3d eq_7_22 = (Eigen::Matrix3d() << 0, -1, 0, 1, 0, 0, 0, 0, 1).finished();
  EXPECT_NEAR((rig.left_mount.R_BC - eq_7_22).norm(), 0.0, 1e-9);
  EXPECT_NEAR((rig.left_mount.t_BC - Eigen::Vector3d(0.057, -0.057, 0.055)).norm(), 0.0, 1e-9);
  EXPECT_NEAR((rig.right_mount.t_BC - Eigen::Vector3d(0.057, 0.057, 0.055)).norm(), 0.0, 1e-9);
  EXPECT_NEAR(rig.baseline_m(), 0.114, 1e-9);
  // The right camera lies along the left camera's +x (image right), turned about 4 degrees.
  const Eigen::Vector3d right_in_left = -rig.R_right_left().transpose() * rig.T_right_left();
  EXPECT_GT(right_in_left.x(), 0.113);
  EXPECT_NEAR(Eigen::AngleAxisd(rig.R_right_left()).angle() * 180.0 / M_PI, 4.07, 0.05);
  EXPECT_NEAR(rig.R_right_left().determinant(), 1.0, 1e-9);
}

TEST(CameraModel, LeftCameraSitsAtTheMountAndLooksDown) {
  const SimStereoRig rig = shipped_rig(CameraParams());
  const CameraPose pose = camera_pose_over_floor(rig.left_mount, Eigen::Vector3d(0, 0, -1.5), Eigen::Quaterniond::Identity());
  const Eigen::Vector3d centre = -pose.R.transpose() * pose.t;
  EXPECT_NEAR((centre - Eigen::Vector3d(0.057, -0.057, -1.5 + 0.055)).norm(), 0.0, 1e-12);
  EXPECT_NEAR((pose.R.row(2).transpose() - Eigen::Vector3d(0, 0, 1)).norm(), 0.0, 1e-12);   // z: down
  EXPECT_NEAR((pose.R.row(0).transpose() - Eigen::Vector3d(0, 1, 0)).norm(), 0.0, 1e-12);   // x: east
  EXPECT_NEAR((pose.R.row(1).transpose() - Eigen::Vector3d(-1, 0, 0)).norm(), 0.0, 1e-12);  // y: south
}

TEST(CameraModel, FloorPhotographLiesWhereOpenCvsRaysMeetTheFloor) {
  // A smooth synthetic photograph (so that the comparison does not depend on the sampling filter).
  const std::string path = ::testing::TempDir() + "/floor_" + std::to_string(getpid()) + ".png";
  cv::Mat photo(256, 256, CV_8UC1);
  for (int r = 0; r < 256; ++r)
    for (int c = 0; c < 256; ++c)
      photo.at<uint8_t>(r, c) = static_cast<uint8_t>(128 + 90 * std::sin(2 * CV_PI * c / 256.0) * std::cos(2 * CV_PI * r / 256.0));
  ASSERT_TRUE(cv::imwrite(path, photo));
  CameraParams params = clean_params();
  params.floor_texture = path;
  params.floor_texture_m = 4.0;  // 1.6 cm texels: the pattern varies slowly on the pixel scale
  params.floor_texture_contrast = 0.2;
  params.floor_grey = 120.0;  // no saturation
  const SimStereoRig rig = shipped_rig(params);
  StereoCameraRenderer renderer(params, rig, {}, Rng(1, "camera"));
  const Eigen::Vector3d p(0.3, -0.2, -1.4);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.1, Eigen::Vector3d(1, 1, 0).normalized()));
  cv::Mat left, right;
  renderer.render(p, q, false, left, right);
  cv::Mat g;
  photo.convertTo(g, CV_64F);
  cv::Scalar mean, sigma;
  cv::meanStdDev(g, mean, sigma);
  const CameraPose pose = camera_pose_over_floor(rig.left_mount, p, q);
  cv::RNG rng(7);
  for (int i = 0; i < 60; ++i) {
    const cv::Point2d px(rng.uniform(200.0, 460.0), rng.uniform(120.0, 320.0));
    std::vector<cv::Point2d> ray;
    cv::undistortPoints(std::vector<cv::Point2d>{px}, ray, cv::Mat(camera_matrix(rig.left)), cv::Mat(distortion(rig.left)));
    const Eigen::Vector3d d = pose.R.transpose() * Eigen::Vector3d(ray[0].x, ray[0].y, 1.0);
    const Eigen::Vector3d c = -pose.R.transpose() * pose.t;
    const Eigen::Vector3d floor = c + (-c.z() / d.z()) * d;
    // The mirrored tile: column along east, row along north, period two photographs.
    auto fold = [](double x, int n) {
      double m = std::fmod(x, 2.0 * n);
      if (m < 0) m += 2.0 * n;
      return m < n ? m : 2.0 * n - 1.0 - m;
    };
    const double texel = 4.0 / 256.0;
    const double col = fold(floor.y() / texel, 256), row = fold(floor.x() / texel, 256);
    const double grey = 128 + 90 * std::sin(2 * CV_PI * std::round(col) / 256.0) * std::cos(2 * CV_PI * std::round(row) / 256.0);
    const double expected = params.floor_grey * (1.0 + params.floor_texture_contrast * (grey - mean[0]) / sigma[0]);
    EXPECT_NEAR(left.at<uint8_t>(cvRound(px.y), cvRound(px.x)), expected, 4.0) << px;
  }
  std::filesystem::remove(path);
}

// A vehicle moving north at 1 m/s, 1.5 m up.
VehiclePose moving(double t) { return VehiclePose{Eigen::Vector3d(1.0 * t - 0.05, 0.02, -1.5), Eigen::Quaterniond::Identity()}; }

TEST(CameraModel, InterlacedFieldsShowTheVehicleAtTheirOwnTimes) {
  CameraParams progressive = clean_params(), interlaced = clean_params();
  interlaced.interlaced = true;
  const SimStereoRig rig = shipped_rig(progressive);
  const auto scene = make_floor_scene(progressive, Rng(3, "floor"));
  StereoCameraRenderer a(interlaced, rig, scene, Rng(3, "camera")), b(progressive, rig, scene, Rng(3, "camera"));
  cv::Mat frame, r, first, second;
  a.render(moving, 0.1, false, frame, r);
  b.render(moving, 0.1 - 1.0 / 60.0, false, first, r);
  b.render(moving, 0.1, false, second, r);
  ASSERT_GT(cv::norm(first, second, cv::NORM_INF), 50.0);  // the star moved between the fields
  for (int row = 0; row < frame.rows; ++row) {
    const cv::Mat& expected = row % 2 == 0 ? first : second;
    ASSERT_EQ(cv::norm(frame.row(row), expected.row(row), cv::NORM_INF), 0.0) << "row " << row;
  }
}

TEST(CameraModel, MotionBlurIsTheShutterIntegralAndKeepsTheInk) {
  CameraParams sharp = clean_params(), blurred = clean_params();
  blurred.exposure_s = 0.008;  // 8 mm of travel at 1 m/s: about 2.4 px at 1.5 m
  const SimStereoRig rig = shipped_rig(sharp);
  std::vector<FloorShape> star_only{make_floor_scene(sharp, Rng(3, "floor")).front()};
  StereoCameraRenderer a(blurred, rig, star_only, Rng(3, "camera")), b(sharp, rig, star_only, Rng(3, "camera"));
  cv::Mat blur_img, sharp_img, r;
  a.render(moving, 0.3, false, blur_img, r);
  EXPECT_GE(a.last_blur_samples(), 4);
  b.render(moving, 0.3 - 0.004, false, sharp_img, r);  // mid-exposure
  // Ink (darkness below the floor) is conserved.
  auto ink = [&](const cv::Mat& m) { return cv::sum(cv::Scalar(sharp.floor_grey) - m)[0]; };
  EXPECT_NEAR(ink(blur_img) / ink(sharp_img), 1.0, 0.01);
  // The shutter integral, approximated finely (64 sharp renders over the exposure), is what the
  // blurred image shows; the mid-exposure instant is not.
  cv::Mat reference = cv::Mat::zeros(blur_img.size(), CV_64F), instant, f;
  for (int k = 0; k < 64; ++k) {
    b.render(moving, 0.3 - 0.008 * (k + 0.5) / 64.0, false, instant, r);
    instant.convertTo(f, CV_64F);
    reference += f / 64.0;
  }
  blur_img.convertTo(f, CV_64F);
  const double blur_error = cv::norm(f, reference, cv::NORM_L1);
  sharp_img.convertTo(f, CV_64F);
  const double sharp_error = cv::norm(f, reference, cv::NORM_L1);
  std::printf("L1 from the shutter integral: blurred %.0f, mid-exposure instant %.0f\n", blur_error, sharp_error);
  EXPECT_LT(blur_error, 0.25 * sharp_error);
  // Still: one exposure, identical to a sharp render.
  a.render(Eigen::Vector3d(0, 0, -1.5), Eigen::Quaterniond::Identity(), false, blur_img, r);
  b.render(Eigen::Vector3d(0, 0, -1.5), Eigen::Quaterniond::Identity(), false, sharp_img, r);
  EXPECT_EQ(a.last_blur_samples(), 1);
  EXPECT_EQ(cv::norm(blur_img, sharp_img, cv::NORM_INF), 0.0);
}

TEST(CameraModel, JpegCompressionIsTheCodecsRoundTrip) {
  CameraParams plain = clean_params(), compressed = clean_params();
  compressed.jpeg_quality = 60;
  const SimStereoRig rig = shipped_rig(plain);
  const auto scene = make_floor_scene(plain, Rng(3, "floor"));
  StereoCameraRenderer a(compressed, rig, scene, Rng(3, "camera")), b(plain, rig, scene, Rng(3, "camera"));
  cv::Mat jl, jr, pl, pr;
  a.render(Eigen::Vector3d(0, 0, -1.2), Eigen::Quaterniond::Identity(), false, jl, jr);
  b.render(Eigen::Vector3d(0, 0, -1.2), Eigen::Quaterniond::Identity(), false, pl, pr);
  std::vector<uint8_t> bytes;
  cv::imencode(".jpg", pl, bytes, {cv::IMWRITE_JPEG_QUALITY, 60});
  EXPECT_EQ(cv::norm(jl, cv::imdecode(bytes, cv::IMREAD_GRAYSCALE), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(jl, pl, cv::NORM_INF), 2.0);
}

}  // namespace
}  // namespace quad::sim
