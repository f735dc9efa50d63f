// The ground cameras in the loop, in ctest: the simulator renders the fixed room cameras (seed 003 table
// 6.1) seeing the vehicle's colour balls, a separate `vision_station track --source sim:` process tracks
// them and its VISION_POSITION_ESTIMATE crosses the emulated radio to the real quad_firmware, which flies
// on those fixes alone (onboard cameras and the simulated fix off). The station's room calibration
// (`calibrate-room` on boards the simulator renders) is checked against the simulator's cameras with
// OpenCV's projection; the hold against the target of 2 cm horizontal std; the association against the
// rendered truth. Free-running cameras: every frame carries its own capture time.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "loop_session.h"
#include "loop_summary.h"
#include "quad/sim/ground_camera.h"
#include "quad/sim/hil_session.h"
#include "quad/sim/scenario.h"

namespace quad::sim {
namespace {

std::string run_dir(const std::string& name) {
  return std::string(::testing::TempDir()) + "/quad_ground_" + name + "_" + std::to_string(getpid());
}

Scenario ground_scenario(const std::vector<ScenarioOverride>& extra) {
  // The shipped scenario, shortened: a 16 s hold and no landing.
  std::vector<ScenarioOverride> o{{"duration_s", "29"}, {"commands.3.at_s", "28.5"}, {"metrics.hold_end_s", "28"}};
  o.insert(o.end(), extra.begin(), extra.end());
  return load_scenario(std::string(QUAD_SIM_SOURCE_DIR) + "/scenarios/ground_cameras.yaml", o);
}

SessionResult fly(const Scenario& s, const std::string& out) {
  return run_session(s, loop_session_options(out));
}

// The station's room file against the simulator's cameras: optical centres, and pixels of points in the
// flight volume projected by OpenCV through the calibration and by the simulator's own lens model.
void check_room_calibration(const std::string& file, const GroundCameraParams& params) {
  cv::FileStorage fs(file, cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened()) << file;
  const std::vector<GroundCamera> truth = ground_cameras_from(params);
  ASSERT_EQ(static_cast<int>(fs["cameras"]), static_cast<int>(truth.size()));
  for (size_t k = 0; k < truth.size(); ++k) {
    cv::Mat K, D, R, t;
    const std::string c = "camera_" + std::to_string(k) + "_";
    fs[c + "K"] >> K;
    fs[c + "D"] >> D;
    fs[c + "R_CI"] >> R;
    fs[c + "t_CI"] >> t;
    ASSERT_FALSE(K.empty() || D.empty() || R.empty() || t.empty()) << file;
    cv::Mat centre = -R.t() * t;
    const Eigen::Vector3d true_centre = truth[k].centre_ned();
    const double centre_error = std::hypot(centre.at<double>(0) - true_centre.x(), centre.at<double>(1) - true_centre.y(),
                                           centre.at<double>(2) - true_centre.z());
    std::vector<cv::Point3d> points;
    for (double n = -0.5; n <= 0.51; n += 0.25)
      for (double e = -0.5; e <= 0.51; e += 0.25)
        for (double h = 0.3; h <= 1.51; h += 0.3) points.emplace_back(n, e, -h);
    cv::Mat rvec;
    cv::Rodrigues(R, rvec);
    std::vector<cv::Point2d> pixels;
    cv::projectPoints(points, rvec, t, K, D, pixels);
    double worst = 0.0;
    const double valid = lens_fold_radius(truth[k].lens);
    for (size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d p = truth[k].R_CI * Eigen::Vector3d(points[i].x, points[i].y, points[i].z) + truth[k].t_CI;
      const auto uv = project_lens(truth[k].lens, valid, p);
      ASSERT_TRUE(uv.has_value());
      worst = std::max(worst, std::hypot(uv->x() - pixels[i].x, uv->y() - pixels[i].y));
    }
    std::printf("[figure] room calibration camera %zu: centre error %.2f mm, flight-volume reprojection max %.3f px\n", k,
                1e3 * centre_error, worst);
    EXPECT_LT(centre_error, 0.01);
    EXPECT_LT(worst, 1.0);
  }
}

TEST(GroundCameras, HoldOnTheRoomCamerasAlone) {
  const std::string out = run_dir("hold");
  const Scenario s = ground_scenario({});
  const SessionResult r = fly(s, out);
  ASSERT_TRUE(r.complete) << r.reason;
  EXPECT_FALSE(r.crashed);
  const std::string summary = slurp(out + "/summary.json");
  std::printf("[figure] ground cameras hold 16 s: %s\n", summary.c_str());
  check_room_calibration(out + "/room_calib.yaml", s.ground_cameras);
  EXPECT_LE(json_number(summary, {"hold", "horizontal", "std_2d"}), 0.02) << summary;
  EXPECT_GT(json_number(summary, {"hold", "samples"}), 1590.0);
  // Every set answered (but one in flight at the end), a fix from nearly every one, none from the
  // simulated star fix (off).
  const double sets = json_number(summary, {"ground_station", "sets_captured"});
  EXPECT_NEAR(sets, 29.0 * 30.0, 2.0);
  EXPECT_GE(json_number(summary, {"ground_station", "sets_answered"}), sets - 1.0);
  EXPECT_GT(json_number(summary, {"ground_station", "fixes"}), 0.98 * sets);
  EXPECT_EQ(json_number(summary, {"vision_fixes_sent"}), 0.0);
  EXPECT_EQ(json_number(summary, {"ground_station", "association_errors"}), 0.0) << summary;
  EXPECT_GT(json_number(summary, {"ground_station", "pixels_checked"}), 0.98 * 8.0 * sets);
  EXPECT_LT(json_number(summary, {"ground_station", "fix_error_m", "p95"}), 0.005);
  // Capture to the firmware: the configured 30 ms, the radio's 57600 baud and latency, the next step.
  const double latency = json_number(summary, {"ground_station", "fix_latency_s", "median"});
  EXPECT_GT(latency, 0.030);
  EXPECT_LT(latency, 0.080);
  EXPECT_GT(json_number(summary, {"ground_station", "processing_us", "count"}), sets - 2.0);
  EXPECT_EQ(json_number(summary, {"ground_station", "capture_skew_us", "max"}), 0.0);
}

TEST(GroundCameras, FreeRunningCamerasCarryTheirOwnCaptureTimes) {
  const std::string out = run_dir("free");
  // Camera 1 captures 13 ms after camera 0; the station's fix stands for the mean time.
  const Scenario s = ground_scenario({{"ground_cameras.trigger", "free"}, {"ground_cameras.phase_s", "[0.0, 0.013]"},
                                      {"duration_s", "22"}, {"commands.3.at_s", "21.5"}, {"metrics.hold_end_s", "21"}});
  const SessionResult r = fly(s, out);
  ASSERT_TRUE(r.complete) << r.reason;
  EXPECT_FALSE(r.crashed);
  const std::string summary = slurp(out + "/summary.json");
  std::printf("[figure] ground cameras free-running: %s\n", summary.c_str());
  // Each frame is captured at the first physics step (1 ms) at or after its phase.
  EXPECT_NEAR(json_number(summary, {"ground_station", "capture_skew_us", "median"}), 13000.0, 1000.0);
  EXPECT_EQ(json_number(summary, {"ground_station", "association_errors"}), 0.0) << summary;
  const double sets = json_number(summary, {"ground_station", "sets_captured"});
  EXPECT_GT(json_number(summary, {"ground_station", "fixes"}), 0.98 * sets);
  EXPECT_LE(json_number(summary, {"hold", "horizontal", "std_2d"}), 0.02) << summary;
  // Hovering, the vehicle moves millimetres in 13 ms: the skew costs little.
  EXPECT_LT(json_number(summary, {"ground_station", "fix_error_m", "p95"}), 0.005);
}

}  // namespace
}  // namespace quad::sim
