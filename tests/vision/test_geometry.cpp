// Geometry and configuration of the vision station: the thesis rig, the camera-to-body transform
// (eq. 7.22) and the vehicle position (eq. 8.5 with its erratum), the calibration file, the row gate of
// the stereo match and the ROI tracker.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/settings_file.h"
#include "quad/vision/star_pose.h"
#include "quad/vision/stereo_locator.h"
#include "star_scenes.h"

namespace quad::vision {
namespace {

TEST(ThesisRigTest, RectifiedRigMatchesTable72AndTheBaseline) {
  const StereoCalibration c = rectify(thesis_stereo_rig());
  std::printf("[vision] thesis rig rectified: f %.1f px (table 7.2: 458.9), c (%.1f, %.1f), baseline %.4f m\n",
              c.rectified_focal(), c.P1(0, 2), c.P1(1, 2), c.baseline());
  EXPECT_NEAR(c.baseline(), kThesisBaseline, 1e-9);
  // fx = s·f, fy = f (eq. 7.26a) reproduces table 7.2's rectified focal length.
  EXPECT_NEAR(c.rectified_focal(), 458.9, 0.1);
  // R is a proper rotation of a few degrees (eq. 7.34 rotates each camera by ~4°).
  EXPECT_NEAR(cv::determinant(cv::Mat(c.rig.R)), 1.0, 1e-9);
  const double angle = std::acos(std::clamp((cv::trace(c.rig.R) - 1.0) / 2.0, -1.0, 1.0)) * 180.0 / CV_PI;
  EXPECT_GT(angle, 1.0);
  EXPECT_LT(angle, 10.0);
  // Rectification makes the baseline horizontal: both rectified centres differ only in x.
  EXPECT_NEAR(c.P2(1, 3), 0.0, 1e-9);
  EXPECT_NEAR(c.P1(1, 2), c.P2(1, 2), 1e-9);
}

TEST(NearRectifierTest, AgreesWithOpenCvsLensModelAndInvertsItFromAPixelOff) {
  // The thesis lenses are strongly distorted (κ1 ≈ −0.5). The oracle is OpenCV's own forward model:
  // a rectified pixel's ray (Rᵀ P⁻¹ q) through cv::projectPoints with the camera's K and D. Newton on the
  // forward map must land on the rectified pixel from a guess 1.5 px off, over the frame out to 50° off
  // the axis (the station's fixes reach 55°; the lens model folds over not far beyond).
  const StereoCalibration c = rectify(thesis_stereo_rig());
  for (int camera = 0; camera < 2; ++camera) {
    const NearRectifier near(c, camera);
    const cv::Matx33d& K = camera == 0 ? c.rig.left.K : c.rig.right.K;
    const cv::Mat D(camera == 0 ? c.rig.left.D : c.rig.right.D);
    const cv::Matx33d& R = camera == 0 ? c.R1 : c.R2;
    const cv::Matx34d& P = camera == 0 ? c.P1 : c.P2;
    const cv::Matx33d back = R.t() * cv::Matx33d(P(0, 0), P(0, 1), P(0, 2), P(1, 0), P(1, 1), P(1, 2), P(2, 0), P(2, 1), P(2, 2)).inv();
    double worst_forward = 0.0, worst_inverse = 0.0;
    int points = 0;
    for (double u = -100.0; u < c.rig.image_size.width + 100; u += 40.0) {
      for (double v = -100.0; v < c.rig.image_size.height + 100; v += 40.0) {
        const cv::Point2d q(u, v);
        const cv::Vec3d ray = back * cv::Vec3d(u, v, 1.0);
        if (std::acos(ray[2] / cv::norm(ray)) > 50.0 * CV_PI / 180.0) continue;
        std::vector<cv::Point2d> raw;
        cv::projectPoints(std::vector<cv::Point3d>{cv::Point3d(ray)}, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, raw);
        worst_forward = std::max(worst_forward, cv::norm(near.raw(q) - raw[0]));
        worst_inverse = std::max(worst_inverse, cv::norm(near.rectified(raw[0], q + cv::Point2d(1.1, -1.0)) - q));
        ++points;
      }
    }
    std::printf("[vision] NearRectifier camera %d, %d points: forward within %.1e px of projectPoints, inverse "
                "within %.1e px\n", camera, points, worst_forward, worst_inverse);
    EXPECT_GT(points, 200);
    EXPECT_LT(worst_forward, 1e-6) << "camera " << camera;
    // The iteration stops within 1e-6 px on the raw side; out at 50° a raw pixel spans up to ~20
    // rectified ones.
    EXPECT_LT(worst_inverse, 1e-4) << "camera " << camera;
  }
}

TEST(CameraMountTest, Eq722MapsImageAxesOntoBodyAxes) {
  const CameraMount mount = thesis_camera_mount();
  // Straight below the left camera at 1.5 m: the camera's offset plus the depth along body z (down).
  const cv::Vec3d below = camera_to_body(mount, cv::Vec3d(0, 0, 1.5));
  EXPECT_NEAR(below[0], 0.057, 1e-12);
  EXPECT_NEAR(below[1], -0.057, 1e-12);
  EXPECT_NEAR(below[2], 1.555, 1e-12);
  // Image right (camera +x) is body right (+y); image down (camera +y) is body backward (−x).
  const cv::Vec3d right = camera_to_body(mount, cv::Vec3d(0.3, 0, 1.5)) - below;
  const cv::Vec3d down = camera_to_body(mount, cv::Vec3d(0, 0.3, 1.5)) - below;
  EXPECT_NEAR(right[1], 0.3, 1e-12);
  EXPECT_NEAR(down[0], -0.3, 1e-12);
}

TEST(CameraMountTest, Eq85ErratumPutsAHoveringVehicleAboveTheStar) {
  const CameraMount mount = thesis_camera_mount();
  // Level vehicle (R_IB = I), star 1.5 m straight below the left camera: the vehicle is at negative
  // down (above the star) and offset by the camera's mounting position.
  const cv::Vec3d p = vehicle_position_from_star(cv::Matx33d::eye(), mount, cv::Vec3d(0, 0, 1.5));
  EXPECT_NEAR(p[2], -1.555, 1e-12);
  EXPECT_NEAR(p[0], -0.057, 1e-12);
  EXPECT_NEAR(p[1], 0.057, 1e-12);
  // Yawed 90° (body x points east): a star ahead of the vehicle is east of it, so the vehicle's position
  // relative to the star is west (negative east).
  const cv::Matx33d yaw90(0, -1, 0, 1, 0, 0, 0, 0, 1);
  const cv::Vec3d q = vehicle_position_from_star(yaw90, mount, cv::Vec3d(0, -0.5, 1.5));  // image up = ahead
  const cv::Vec3d star_body = camera_to_body(mount, cv::Vec3d(0, -0.5, 1.5));
  EXPECT_GT(star_body[0], 0.5);  // ahead
  EXPECT_LT(q[1], -0.5);         // vehicle west of the star (star east of the vehicle)
}

class CalibrationFileTest : public ::testing::Test {
 protected:
  std::filesystem::path dir = std::filesystem::temp_directory_path() / ("vision_calib_" + std::to_string(::getpid()));
  void SetUp() override { std::filesystem::create_directories(dir); }
  void TearDown() override { std::filesystem::remove_all(dir); }
};

TEST_F(CalibrationFileTest, RoundTripKeepsEveryMatrix) {
  const StereoCalibration c = rectify(thesis_stereo_rig());
  const std::string path = (dir / "calib.yaml").string();
  save_calibration(c, path);
  const StereoCalibration r = load_calibration(path);
  EXPECT_EQ(r.rig.image_size, c.rig.image_size);
  EXPECT_LT(cv::norm(cv::Mat(r.rig.left.K), cv::Mat(c.rig.left.K)), 1e-9);
  EXPECT_LT(cv::norm(cv::Mat(r.rig.right.D), cv::Mat(c.rig.right.D)), 1e-12);
  EXPECT_LT(cv::norm(cv::Mat(r.rig.T), cv::Mat(c.rig.T)), 1e-12);
  EXPECT_LT(cv::norm(cv::Mat(r.P2), cv::Mat(c.P2)), 1e-9);
  EXPECT_LT(cv::norm(cv::Mat(r.Q), cv::Mat(c.Q)), 1e-9);
}

TEST_F(CalibrationFileTest, MissingKeyIsNamed) {
  const std::string path = (dir / "partial.yaml").string();
  {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    fs << "image_width" << 728 << "image_height" << 488 << "K1" << cv::Mat::eye(3, 3, CV_64F);
  }
  try {
    load_calibration(path);
    FAIL() << "accepted a file without D1";
  } catch (const CalibrationFileError& e) {
    EXPECT_NE(std::string(e.what()).find("missing key 'D1'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_THROW(load_calibration((dir / "absent.yaml").string()), CalibrationFileError);
  std::ofstream(dir / "garbage.yaml") << "this is : not [ yaml\n";
  EXPECT_THROW(load_calibration((dir / "garbage.yaml").string()), CalibrationFileError);
}

TEST_F(CalibrationFileTest, SettingsFileOverridesByNameAndRejectsUnknownKeys) {
  const std::string path = (dir / "settings.yaml").string();
  {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    fs << "min_area_px" << 500.0 << "vertex_count_tolerance" << 2 << "track_roi" << 0
       << "camera_to_body_t" << cv::Mat(cv::Vec3d(0.1, 0.0, 0.05));
  }
  const StationSettings s = load_station_settings(path);
  EXPECT_EQ(s.locator.detector.min_area_px, 500.0);
  EXPECT_EQ(s.locator.detector.vertex_count_tolerance, 2);
  EXPECT_FALSE(s.locator.track_roi);
  EXPECT_EQ(s.locator.detector.min_aspect, 0.7);  // untouched keys keep the thesis defaults
  EXPECT_EQ(s.mount.t_BC, cv::Vec3d(0.1, 0.0, 0.05));
  EXPECT_EQ(s.mount.R_BC, thesis_camera_mount().R_BC);

  const std::string bad = (dir / "bad.yaml").string();
  {
    cv::FileStorage fs(bad, cv::FileStorage::WRITE);
    fs << "min_area" << 500.0;
  }
  try {
    load_station_settings(bad);
    FAIL() << "unknown key accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("unknown setting 'min_area'"), std::string::npos) << e.what();
  }
  {
    cv::FileStorage fs(bad, cv::FileStorage::WRITE);
    fs << "min_aspect" << "wide";
  }
  EXPECT_THROW(load_station_settings(bad), std::runtime_error);
}

class LocatorTest : public ::testing::Test {
 protected:
  StereoRig rig = thesis_stereo_rig();
  StereoCalibration calibration = rectify(rig);
};

TEST_F(LocatorTest, RowGateRejectsAVerticallyShiftedRightImage) {
  cv::RNG rng(31);
  const auto scene = testing::random_star_scene(rig, rng, testing::StarSceneRanges{});
  ASSERT_TRUE(scene);
  StereoStarLocator locator(calibration, LocatorSettings{});
  auto shifted = [&](double dy) {
    cv::Mat out;
    cv::warpAffine(scene->right, out, cv::Matx23d(1, 0, 0, 0, 1, dy), scene->right.size(), cv::INTER_LINEAR,
                   cv::BORDER_REPLICATE);
    locator.reset_tracking();
    return locator.locate(scene->left, out);
  };
  const StarFix small = shifted(1.0);
  EXPECT_TRUE(small.found) << "a 1 px shift is within the 2.5 px tolerance";
  const StarFix large = shifted(12.0);
  EXPECT_FALSE(large.found) << "rows differ by ~12 px: the stereo match must fail";
}

TEST_F(LocatorTest, TrackingRoiAgreesWithFullFrameAndFallsBack) {
  cv::RNG rng(32);
  testing::StarSceneRanges ranges;
  ranges.min_height = 1.2;
  ranges.max_height = 2.0;
  LocatorSettings tracked_settings;
  LocatorSettings full_settings;
  full_settings.track_roi = false;
  StereoStarLocator tracked(calibration, tracked_settings);
  StereoStarLocator full(calibration, full_settings);
  int roi_frames = 0;
  for (int i = 0; i < 12; ++i) {
    const auto scene = testing::random_star_scene(rig, rng, ranges);
    ASSERT_TRUE(scene);
    // Each scene twice: the second frame is searched in the ROI of the first.
    for (int repeat = 0; repeat < 2; ++repeat) {
      const StarFix a = tracked.locate(scene->left, scene->right);
      const StarFix b = full.locate(scene->left, scene->right);
      ASSERT_TRUE(a.found && b.found);
      roi_frames += a.used_roi ? 1 : 0;
      // Two binarisations of the same pair (local vs whole-image floor estimate) differ by contour
      // quantisation, which the lens magnifies near the image border; both must stay accurate.
      EXPECT_LT(cv::norm(a.p_left - b.p_left), 0.01 * cv::norm(b.p_left));
      EXPECT_LT(cv::norm(a.p_left - scene->truth_left), 0.02 * cv::norm(scene->truth_left));
    }
  }
  // Every repeated frame used the ROI; scene changes (star elsewhere) fell back to the full frame.
  EXPECT_GE(roi_frames, 12);
  // A blank pair after a fix: no stale position.
  const cv::Mat blank(rig.image_size, CV_8UC1, cv::Scalar(200));
  EXPECT_FALSE(tracked.locate(blank, blank).found);
}

}  // namespace
}  // namespace quad::vision
