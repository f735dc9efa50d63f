// The rendered stereo cameras against the vision station that consumes them, as in a flight: chessboards
// rendered through the simulator's own camera model calibrate the station (`vision_station calibrate`),
// the calibration recovers the simulator's lenses and baseline, and the station so calibrated finds the
// star where the truth says, from many heights and attitudes.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <opencv2/calib3d.hpp>

#include "quad/sim/frames.h"
#include "quad/sim/station_calibration.h"
#include "quad/sim/stereo_camera.h"
#include "quad/sim/vehicle.h"
#include "quad/sim/vision_fix.h"
#include "quad/vision/settings_file.h"
#include "quad/vision/star_pose.h"
#include "quad/vision/stereo_calibration.h"
#include "quad/vision/stereo_locator.h"

namespace quad::sim {
namespace {

namespace vis = quad::vision;

Eigen::Quaterniond attitude(double roll, double pitch, double yaw) {
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
}

SimStereoRig shipped_rig(const CameraParams& params) {
  VehicleParams vp;
  vp.model_path = QUAD_SIM_SOURCE_DIR "/models/quad_c.xml";
  Vehicle vehicle(vp);
  return stereo_rig_from_model(vehicle.model(), params, vp.model_path);
}

// The station's calibration made from the simulator's own cameras (lenses and mounts), not estimated.
vis::StereoCalibration exact_calibration(const SimStereoRig& rig) {
  auto intrinsics = [](const LensParams& l) {
    vis::CameraIntrinsics c;
    c.K = cv::Matx33d(l.fx, 0.0, l.cx, 0.0, l.fy, l.cy, 0.0, 0.0, 1.0);
    c.D = cv::Vec<double, 5>(l.k1, l.k2, l.p1, l.p2, l.k3);
    return c;
  };
  vis::StereoRig r;
  r.image_size = cv::Size(rig.width, rig.height);
  r.left = intrinsics(rig.left);
  r.right = intrinsics(rig.right);
  const Eigen::Matrix3d R = rig.R_right_left();
  const Eigen::Vector3d T = rig.T_right_left();
  for (int i = 0; i < 9; ++i) r.R(i / 3, i % 3) = R(i / 3, i % 3);
  r.T = cv::Vec3d(T.x(), T.y(), T.z());
  return vis::rectify(r);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The station's calibration as the simulator makes it for a flight: chessboards rendered through the
// simulator's cameras, then `vision_station calibrate` (the built executable), cached in the build tree
// under a key of the cameras and that executable.
class StereoCamera : public ::testing::Test {
 protected:
  static std::string calibration(const std::string& cache) {
    return station_calibration_file(shipped_rig(CameraParams()), CameraParams(), {QUAD_VISION_STATION, "calibrate"}, cache,
                                    [](const std::string& line) { std::printf("%s\n", line.c_str()); });
  }
  static void SetUpTestSuite() { file_ = calibration(QUAD_TEST_CALIBRATION_CACHE); }
  static std::string file_;
};
std::string StereoCamera::file_;

TEST_F(StereoCamera, ChessboardCalibrationRecoversTheSimulatorsCameras) {
  // Calibrated afresh here (an empty cache), not taken from an earlier run.
  const std::string cache = ::testing::TempDir() + "/sim_calib_" + std::to_string(getpid());
  std::filesystem::remove_all(cache);
  const std::string file = calibration(cache);
  const SimStereoRig rig = shipped_rig(CameraParams());
  cv::FileStorage fs(file, cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened()) << file;
  cv::Mat K1, K2, R, T;
  fs["K1"] >> K1;
  fs["K2"] >> K2;
  fs["R"] >> R;
  fs["T"] >> T;
  for (const auto& [K, lens] : {std::pair<cv::Mat, LensParams>{K1, rig.left}, {K2, rig.right}}) {
    std::printf("fx %.2f (true %.2f), fy %.2f (%.2f), cx %.2f (%.2f), cy %.2f (%.2f)\n", K.at<double>(0, 0), lens.fx,
                K.at<double>(1, 1), lens.fy, K.at<double>(0, 2), lens.cx, K.at<double>(1, 2), lens.cy);
    EXPECT_NEAR(K.at<double>(0, 0) / lens.fx, 1.0, 0.005);
    EXPECT_NEAR(K.at<double>(1, 1) / lens.fy, 1.0, 0.005);
    EXPECT_NEAR(K.at<double>(0, 2), lens.cx, 2.0);
    EXPECT_NEAR(K.at<double>(1, 2), lens.cy, 2.0);
  }
  std::printf("baseline %.5f m (true %.5f)\n", cv::norm(T), rig.baseline_m());
  EXPECT_NEAR(cv::norm(T) / rig.baseline_m(), 1.0, 0.005);
  Eigen::Matrix3d Re;
  for (int i = 0; i < 9; ++i) Re(i / 3, i % 3) = R.at<double>(i / 3, i % 3);
  EXPECT_LT(Eigen::AngleAxisd(Re.transpose() * rig.R_right_left()).angle() * 180.0 / M_PI, 0.1);
  // A second request is served from the cache, without recalibrating.
  const auto before = std::filesystem::last_write_time(file);
  EXPECT_EQ(calibration(cache), file);
  EXPECT_EQ(std::filesystem::last_write_time(file), before);
  // Other cameras are another key.
  CameraParams other;
  other.left.fx *= 1.01;
  EXPECT_THROW(station_calibration_file(shipped_rig(other), other, {"/nonexistent/vision_station", "calibrate"}, cache,
                                        [](const std::string&) {}),
               CalibrationError);
  std::filesystem::remove_all(cache);
}

TEST_F(StereoCamera, CalibratedStationFindsTheRenderedStarWhereTheTruthIs) {
  CameraParams params;
  params.enabled = true;
  StereoCameraRenderer renderer(params, shipped_rig(params), make_floor_scene(params, Rng(5, "floor")), Rng(5, "camera"));
  vis::LocatorSettings settings;
  settings.track_roi = false;
  vis::StereoStarLocator locator(vis::load_calibration(file_), settings);
  const vis::CameraMount mount = vis::thesis_camera_mount();  // the station's default = the MJCF's left camera
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

// An interlaced frame is stamped at the end of its second field; with `deinterlace: field` the station
// sees the first, one field period earlier (its edge search as well: vision::first_field), and stamps its
// fix with that instant (vision::view_time_offset_us). The vehicle climbs and descends at 1 m/s through
// the same heights: the fix's height error, taken against the truth at the fix's instant, is the same
// climbing and descending (what is left is the static error of the range); against the truth at the
// frame's stamp the two differ by two field periods' travel, 3.3 cm.
TEST_F(StereoCamera, InterlacedFieldFixIsTheVehicleOneFieldPeriodBeforeTheStamp) {
  CameraParams params;
  params.enabled = true;
  params.interlaced = true;
  StereoCameraRenderer renderer(params, shipped_rig(params), make_floor_scene(params, Rng(7, "floor")), Rng(7, "camera"));
  vis::LocatorSettings settings;
  settings.track_roi = false;
  settings.detector.deinterlace = vis::Deinterlace::kField;
  vis::StereoStarLocator locator(vis::load_calibration(file_), settings);
  const vis::CameraMount mount = vis::thesis_camera_mount();
  const vis::StationSettings defaults;
  const double offset_s = 1e-6 * static_cast<double>(vis::view_time_offset_us(settings.detector.deinterlace,
                                                                              defaults.field_period_ms));
  EXPECT_NEAR(offset_s, -1.0 / 59.94, 1e-6);
  std::vector<double> at_view, at_stamp;  // climbing minus descending, per height
  cv::Mat left, right;
  for (double height = 1.0; height <= 1.61; height += 0.1) {
    double view[2] = {NAN, NAN}, stamp[2] = {NAN, NAN};
    for (int k = 0; k < 2; ++k) {
      const double climb = k == 0 ? 1.0 : -1.0, t = 10.0;
      const Eigen::Vector3d p0(0.05, -0.04, -height);
      const Eigen::Quaterniond q = attitude(0.02, -0.03, 0.4);
      const PoseAtTime pose_at = [&](double when) { return VehiclePose{p0 + Eigen::Vector3d(0, 0, -climb * (when - t)), q}; };
      renderer.render(pose_at, t, false, left, right);
      const vis::StarFix fix = locator.locate(left, right);
      if (!fix.found) continue;
      // The star below the vehicle: its body z is the height.
      const double seen = vis::camera_to_body(mount, fix.p_left)[2];
      view[k] = seen - star_in_body_frd(pose_at(t + offset_s).p_ned, q).z();
      stamp[k] = seen - star_in_body_frd(pose_at(t).p_ned, q).z();
    }
    if (std::isnan(view[0]) || std::isnan(view[1])) continue;
    at_view.push_back(view[0] - view[1]);
    at_stamp.push_back(stamp[0] - stamp[1]);
    std::printf("height %.1f m: height error climbing %+.2f mm, descending %+.2f mm (at the stamp %+.2f, %+.2f)\n",
                height, 1e3 * view[0], 1e3 * view[1], 1e3 * stamp[0], 1e3 * stamp[1]);
  }
  ASSERT_GE(at_view.size(), 6u);
  auto rms = [](const std::vector<double>& v) {
    double sum = 0.0;
    for (double x : v) sum += x * x;
    return std::sqrt(sum / static_cast<double>(v.size()));
  };
  std::printf("[figure] climbing minus descending at 1 m/s, %zu heights: RMS %.2f mm at the fix's instant, %.2f mm "
              "at the frame's stamp\n", at_view.size(), 1e3 * rms(at_view), 1e3 * rms(at_stamp));
  EXPECT_LT(rms(at_view), 0.003);
  EXPECT_GT(rms(at_stamp), 0.025);
}

TEST_F(StereoCamera, HiddenStarIsNotFound) {
  CameraParams params;
  StereoCameraRenderer renderer(params, shipped_rig(params), make_floor_scene(params, Rng(5, "floor")), Rng(5, "camera"));
  vis::StereoStarLocator locator(vis::load_calibration(file_), vis::LocatorSettings{});
  cv::Mat left, right;
  renderer.render(Eigen::Vector3d(0, 0, -1.5), attitude(0, 0, 0), false, left, right);
  EXPECT_TRUE(locator.locate(left, right).found);
  renderer.render(Eigen::Vector3d(0, 0, -1.5), attitude(0, 0, 0), true, left, right);
  EXPECT_FALSE(locator.locate(left, right).found);
}

TEST(StereoCameraScene, StationReadsTheMountTheSimulatorWrites) {
  const SimStereoRig rig = shipped_rig(CameraParams());
  const std::string path = ::testing::TempDir() + "/settings_" + std::to_string(getpid()) + ".yaml";
  write_station_settings(path, rig.left_mount, {{"min_area_px", "123"}});
  const vis::StationSettings settings = vis::load_station_settings(path);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(settings.mount.t_BC[i], rig.left_mount.t_BC(i));
    for (int j = 0; j < 3; ++j) EXPECT_EQ(settings.mount.R_BC(i, j), rig.left_mount.R_BC(i, j));
  }
  EXPECT_EQ(settings.locator.detector.min_area_px, 123);
  std::filesystem::remove(path);
}

// Each shape is blended by the area of each pixel it covers: a square's painted area is its true area
// for every direction and sub-pixel position of its edges (a 4 x 4 supersampled cv::fillPoly canvas
// grows every shape by 0.07-0.13 px depending on the edge direction).
TEST(StereoCameraScene, ShapesCoverTheirExactArea) {
  const LensParams lens{500.0, 500.0, 100.0, 100.0, 0.0, 0.0, 0.0, 0.0, 0.0};
  const CameraPose pose{Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, 1.0)};
  cv::Mat albedo, coverage;
  std::vector<double> crossings;
  for (double degrees : {0.0, 10.0, 21.5, 45.0, 68.5, 111.5, 158.5, 201.5}) {
    for (double offset_px : {0.0, 0.1, 0.37}) {
      std::vector<Eigen::Vector2d> square;  // 80 px side (0.16 m at 1 m, f = 500 px)
      for (int k = 0; k < 4; ++k) {
        const double a = (degrees + 45.0 + 90.0 * k) * M_PI / 180.0;
        square.emplace_back(offset_px / 500.0 + 0.08 * std::sqrt(2.0) * std::cos(a), offset_px / 500.0 + 0.08 * std::sqrt(2.0) * std::sin(a));
      }
      albedo.create(200, 200, CV_32F);
      albedo.setTo(cv::Scalar(255.0));
      paint_shapes(lens, lens_fold_radius(lens), pose, {FloorShape{square, 0.0}}, 0, albedo, crossings, coverage);
      const double area = cv::sum(255.0 - albedo)[0] / 255.0;
      // The outward displacement of the edges: (painted − true area) / perimeter.
      EXPECT_NEAR((area - 6400.0) / 320.0, 0.0, 0.002) << degrees << " deg, offset " << offset_px << " px";
    }
  }
}

// The star's attitude the station finds on the rendered cameras, calibrated exactly (the simulator's own
// lenses and mounts): a level star under a level vehicle hovering at 1.2-1.8 m shows no roll or pitch
// beyond the noise (0.05 deg for the median of 40 frames), with the star's tips along the body axes and
// turned 45 deg, from the detector's contours of either deinterlacing. Filling a 4 x 4 supersampled
// cv::fillPoly canvas instead gives +0.4 deg of roll at 1.5 m; edge points at the mid-level crossing
// alone (without the area refinement) -0.16 deg of pitch with the progressive contours.
TEST(StereoCameraScene, StationSeesALevelStarLevel) {
  CameraParams params;
  params.enabled = true;
  const SimStereoRig rig = shipped_rig(params);
  StereoCameraRenderer renderer(params, rig, make_floor_scene(params, Rng(5, "floor")), Rng(5, "camera"));
  cv::Matx33d R_BC;
  for (int i = 0; i < 9; ++i) R_BC(i / 3, i % 3) = rig.left_mount.R_BC(i / 3, i % 3);
  Rng rng(9, "level_star");
  cv::Mat left, right;
  for (vis::Deinterlace deinterlace : {vis::Deinterlace::kField, vis::Deinterlace::kNone}) {
    vis::LocatorSettings settings;
    settings.track_roi = false;
    settings.detector.deinterlace = deinterlace;
    vis::StereoStarLocator locator(exact_calibration(rig), settings);
    for (double yaw_deg : {0.0, 45.0}) {
      std::vector<double> roll, pitch;
      for (int k = 0; k < 40; ++k) {
        const Eigen::Vector3d p(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), -rng.uniform(1.2, 1.8));
        renderer.render(p, attitude(0.0, 0.0, yaw_deg * M_PI / 180.0), false, left, right);
        const vis::StarFix fix = locator.locate(left, right);
        if (!fix.found || !fix.pose.valid) continue;
        // R_SB = R_BSᵀ is the vehicle's attitude relative to the star's NED axes: here its roll and pitch.
        const cv::Matx33d R_SB = vis::star_attitude_in_body(R_BC, fix.pose.R_CS).t();
        roll.push_back(std::atan2(R_SB(2, 1), R_SB(2, 2)) * 180.0 / M_PI);
        pitch.push_back(-std::asin(R_SB(2, 0)) * 180.0 / M_PI);
      }
      const std::string label = std::string("deinterlace ") + vis::to_string(deinterlace) + ", yaw " + std::to_string(static_cast<int>(yaw_deg));
      ASSERT_GE(roll.size(), 36u) << label;
      std::printf("%s deg: %zu poses, median roll %+.3f deg, pitch %+.3f deg\n", label.c_str(), roll.size(), median(roll),
                  median(pitch));
      // The first field's edges are sampled every other row (a fix shows one instant: first_field): a still
      // star's tilt is off by up to 0.15 deg there, 0.03 deg with both fields' rows.
      const double bound = deinterlace == vis::Deinterlace::kField ? 0.2 : 0.12;
      EXPECT_LT(std::fabs(median(roll)), bound) << label;
      EXPECT_LT(std::fabs(median(pitch)), bound) << label;
    }
  }
}

TEST(StereoCameraScene, SameSeedSameImages) {
  CameraParams params;
  const SimStereoRig rig = shipped_rig(params);
  StereoCameraRenderer a(params, rig, make_floor_scene(params, Rng(7, "floor")), Rng(7, "camera"));
  StereoCameraRenderer b(params, rig, make_floor_scene(params, Rng(7, "floor")), Rng(7, "camera"));
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

TEST(StereoCameraScene, FloorSceneShapesDoNotTouch) {
  CameraParams params;
  params.distractors = 12;
  const std::vector<FloorShape> scene = make_floor_scene(params, Rng(11, "floor"));
  ASSERT_EQ(scene.size(), 13u);
  ASSERT_EQ(scene[0].outline.size(), 8u);
  EXPECT_NEAR(scene[0].outline[0].norm(), 0.20, 1e-12);  // star tip, 0.40 m tip to tip
  EXPECT_NEAR(scene[0].outline[1].norm(), 0.08, 1e-12);  // inner vertex at 0.4 of the tip radius
  for (size_t i = 1; i < scene.size(); ++i) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& v : scene[i].outline) c += v;
    c /= static_cast<double>(scene[i].outline.size());
    EXPECT_GT(c.norm(), 0.45);
  }
}

}  // namespace
}  // namespace quad::sim
