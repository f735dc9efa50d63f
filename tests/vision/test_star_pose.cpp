// The star's attitude from both views, on images this test draws itself: its own rig (not the thesis
// rig), its own star outline, projected with cv::projectPoints and filled 4x supersampled; none of the
// station's rig, lens, star or renderer code draws them. Tilt error = angle between the estimated and
// the true star normal; median <= 0.2 deg over all ranges and at each range up to 1.5 m (reported per
// range), and the reported attitude sigma consistent with the errors.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/link/dialect.h"
#include "quad/link/parser.h"

#include "quad/vision/fix_output.h"
#include "quad/vision/star_pose.h"
#include "quad/vision/stereo_locator.h"

namespace quad::vision {
namespace {

// The test's rig: 720x480, mild barrel distortion, 0.12 m baseline, a slight relative rotation.
struct TestRig {
  cv::Size size{720, 480};
  cv::Matx33d K1{470, 0, 362, 0, 468, 236, 0, 0, 1}, K2{474, 0, 355, 0, 473, 243, 0, 0, 1};
  cv::Vec<double, 5> D1{-0.28, 0.09, 0.0005, -0.0003, -0.012}, D2{-0.26, 0.08, -0.0004, 0.0002, -0.01};
  cv::Vec3d r_rel{0.006, -0.012, 0.003};  // right from left, Rodrigues
  cv::Vec3d T{-0.12, 0.0015, 0.0008};
};

// The star's outline in its own plane: four tips at radius 0.2 m on ±x, ±y; the four inner corners at
// 0.08 m on the diagonals; each edge sampled densely so that the lens bends it.
std::vector<cv::Point3d> star_outline() {
  std::vector<cv::Point3d> corners;
  for (int k = 0; k < 8; ++k) {
    const double r = k % 2 == 0 ? 0.2 : 0.08, a = k * CV_PI / 4.0;
    corners.emplace_back(r * std::cos(a), r * std::sin(a), 0.0);
  }
  std::vector<cv::Point3d> outline;
  for (int k = 0; k < 8; ++k) {
    for (int i = 0; i < 60; ++i) outline.push_back(corners[k] + (corners[(k + 1) % 8] - corners[k]) * (i / 60.0));
  }
  return outline;
}

// One view: grey floor with a soft brightness gradient, the dark star, sensor noise.
cv::Mat draw(const cv::Matx33d& K, const cv::Vec<double, 5>& D, const cv::Matx33d& R_cam_star, const cv::Vec3d& t,
             cv::Size size, cv::RNG& rng) {
  constexpr int kSuper = 4;
  std::vector<cv::Point2d> projected;
  cv::Vec3d rvec;
  cv::Rodrigues(R_cam_star, rvec);
  cv::projectPoints(star_outline(), rvec, t, K, D, projected);
  // Vertices with 4 fractional bits on the supersampled grid (fillPoly's `shift`), so that the outline
  // is placed to 1/64 px of the final image.
  constexpr int kShift = 4;
  std::vector<cv::Point> polygon;
  for (const cv::Point2d& p : projected) {
    polygon.emplace_back(cvRound(((p.x + 0.5) * kSuper - 0.5) * (1 << kShift)),
                         cvRound(((p.y + 0.5) * kSuper - 0.5) * (1 << kShift)));
  }
  cv::Mat big(size.height * kSuper, size.width * kSuper, CV_8UC1, cv::Scalar(205));
  cv::fillPoly(big, std::vector<std::vector<cv::Point>>{polygon}, cv::Scalar(35), cv::LINE_8, kShift);
  cv::Mat image;
  cv::resize(big, image, size, 0, 0, cv::INTER_AREA);
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.6);
  cv::Mat noise(size, CV_16SC1);
  rng.fill(noise, cv::RNG::NORMAL, 0, 2.0);
  cv::Mat out;
  image.convertTo(out, CV_16SC1);
  out += noise;
  for (int y = 0; y < size.height; ++y) out.row(y) += cv::Scalar(static_cast<int>(12.0 * y / size.height));
  out.convertTo(out, CV_8UC1);
  return out;
}

double degrees(double rad) { return rad * 180.0 / CV_PI; }

// The test rig in the station's terms (the numbers only; the station rectifies it itself).
StereoRig station_rig_of(const TestRig& rig) {
  StereoRig station_rig;
  station_rig.image_size = rig.size;
  station_rig.left = CameraIntrinsics{rig.K1, rig.D1};
  station_rig.right = CameraIntrinsics{rig.K2, rig.D2};
  cv::Rodrigues(rig.r_rel, station_rig.R);
  station_rig.T = rig.T;
  return station_rig;
}

// Both views of the star at attitude R_LS and centre t_L (left camera frame), the left drawn first.
struct DrawnPair {
  cv::Mat left, right;
};
DrawnPair draw_pair(const TestRig& rig, const cv::Matx33d& R_LS, const cv::Vec3d& t_L, cv::RNG& rng) {
  const cv::Matx33d R_RL = station_rig_of(rig).R;
  DrawnPair pair;
  pair.left = draw(rig.K1, rig.D1, R_LS, t_L, rig.size, rng);
  pair.right = draw(rig.K2, rig.D2, R_RL * R_LS, R_RL * t_L + rig.T, rig.size, rng);
  return pair;
}

// The locator's settings for the drawn pairs: progressive frames, each pair on its own (no tracking).
LocatorSettings drawn_pair_settings() {
  LocatorSettings settings;
  settings.track_roi = false;
  settings.detector.deinterlace = Deinterlace::kNone;
  return settings;
}

// A level star straight below a level vehicle (thesis mount), yawed by `yaw` about the vertical.
struct LevelScene {
  cv::Mat left, right;
  cv::Matx33d R_LS;
};
LevelScene level_scene(const TestRig& rig, double yaw, double range, cv::RNG& rng) {
  LevelScene scene;
  cv::Rodrigues(cv::Vec3d(0, 0, yaw), scene.R_LS);
  DrawnPair pair = draw_pair(rig, scene.R_LS, cv::Vec3d(0.06, 0.0, range), rng);
  scene.left = pair.left;
  scene.right = pair.right;
  return scene;
}

TEST(StarPose, TiltFromIndependentlyDrawnStereoPairs) {
  const TestRig rig;
  const StereoCalibration calibration = rectify(station_rig_of(rig));
  StereoStarLocator locator(calibration, drawn_pair_settings());

  cv::RNG rng(20261202);
  const std::vector<double> ranges{0.6, 1.0, 1.5, 2.0, 2.5};
  std::map<double, std::vector<double>> errors, normalised;
  int drawn = 0, found = 0, posed = 0;
  double pose_us = 0.0, total_us = 0.0;
  for (double range : ranges) {
    for (int i = 0; i < 40; ++i) {
      // Star pose: tilted up to 25 deg about a random axis in its plane, any yaw, anywhere the star
      // stays inside both images.
      const double tilt = rng.uniform(0.0, 25.0) * CV_PI / 180.0, axis = rng.uniform(0.0, 2 * CV_PI);
      cv::Matx33d R_tilt, R_yaw;
      cv::Rodrigues(cv::Vec3d(std::cos(axis), std::sin(axis), 0.0) * tilt, R_tilt);
      cv::Rodrigues(cv::Vec3d(0, 0, rng.uniform(0.0, 2 * CV_PI)), R_yaw);
      const cv::Matx33d R_LS = R_tilt * R_yaw;
      const double lateral = std::max(0.0, 0.45 * range - 0.25);
      const cv::Vec3d t_L(rng.uniform(-lateral, lateral) + 0.06, rng.uniform(-0.6 * lateral, 0.6 * lateral), range);
      const DrawnPair pair = draw_pair(rig, R_LS, t_L, rng);
      ++drawn;
      const StarFix fix = locator.locate(pair.left, pair.right);
      if (!fix.found) continue;
      ++found;
      if (!fix.pose.valid) continue;
      ++posed;
      pose_us += fix.times.pose_us;
      total_us += fix.times.total_us();
      const cv::Vec3d n_true(R_LS(0, 2), R_LS(1, 2), R_LS(2, 2));
      const cv::Vec3d n_est(fix.pose.R_CS(0, 2), fix.pose.R_CS(1, 2), fix.pose.R_CS(2, 2));
      const double error = std::acos(std::clamp(n_true.dot(n_est), -1.0, 1.0));
      errors[range].push_back(degrees(error));
      // The tilt error against the sigma the covariance gives about the two in-plane axes.
      const cv::Vec3d x_axis(fix.pose.R_CS(0, 0), fix.pose.R_CS(1, 0), fix.pose.R_CS(2, 0));
      const cv::Vec3d y_axis(fix.pose.R_CS(0, 1), fix.pose.R_CS(1, 1), fix.pose.R_CS(2, 1));
      const double var = 0.5 * ((x_axis.t() * fix.pose.attitude_cov_C * x_axis)[0] +
                                (y_axis.t() * fix.pose.attitude_cov_C * y_axis)[0]);
      normalised[range].push_back(error / std::sqrt(var));
    }
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? NAN : v[v.size() / 2];
  };
  std::vector<double> all;
  std::printf("[vision] star tilt from both views (%d pairs drawn with cv::projectPoints, %d fixes, %d poses):\n",
              drawn, found, posed);
  for (double range : ranges) {
    std::vector<double> sorted = errors[range];
    std::sort(sorted.begin(), sorted.end());
    const double p95 = sorted.empty() ? NAN : sorted[std::min(sorted.size() - 1, sorted.size() * 95 / 100)];
    std::printf("[vision]   range %.1f m: %zu poses, tilt error median %.3f deg, p95 %.3f deg; error/sigma median %.2f\n",
                range, sorted.size(), median(sorted), p95, median(normalised[range]));
    all.insert(all.end(), sorted.begin(), sorted.end());
    EXPECT_GE(sorted.size(), 36u) << "range " << range;
    // Median <= 0.2 deg up to 1.5 m. Beyond, the disparity across the 0.4 m star is too small for that
    // (a 0.2 deg tilt changes it by 0.013 px tip to tip at 2.5 m): bounded at 0.6 deg and reported.
    EXPECT_LE(median(sorted), range <= 1.5 ? 0.2 : 0.6) << "range " << range;
    // A 2-D Gaussian tilt error has its median at 1.18 sigma: the covariance must be neither far too
    // optimistic nor far too pessimistic (erring on the safe side by up to 4x).
    EXPECT_GT(median(normalised[range]), 0.3) << "range " << range;
    EXPECT_LT(median(normalised[range]), 2.5) << "range " << range;
  }
  std::printf("[vision]   all ranges: tilt error median %.3f deg; pose %.0f us of %.0f us per pair (mean, shared CPU)\n",
              median(all), pose_us / std::max(posed, 1), total_us / std::max(posed, 1));
  EXPECT_LE(median(all), 0.2);
}

// The star's eight corners (star_outline's) placed by R_LS, t_L and projected into the rectified views.
std::array<std::array<cv::Point2d, 8>, 2> rectified_corners(const StereoCalibration& c, const cv::Matx33d& R_LS,
                                                             const cv::Vec3d& t_L) {
  std::array<std::array<cv::Point2d, 8>, 2> out;
  for (int k = 0; k < 8; ++k) {
    const double r = k % 2 == 0 ? 0.2 : 0.08, a = k * CV_PI / 4.0;
    const cv::Vec3d X = c.R1 * (R_LS * cv::Vec3d(r * std::cos(a), r * std::sin(a), 0.0) + t_L);
    for (int view = 0; view < 2; ++view) {
      const cv::Vec3d x = (view == 0 ? c.P1 : c.P2) * cv::Vec4d(X[0], X[1], X[2], 1.0);
      out[view][k] = cv::Point2d(x[0] / x[2], x[1] / x[2]);
    }
  }
  return out;
}

// The disparity gradient of the star's plane (plane_disparity_gradient) against the one the aligned
// outlines measure, on this test's own drawings: the true plane's agrees, and a fit tilted 50° away
// from it (as far stars with distorted outlines were fitted on the evaluation sets) is beyond
// LocatorSettings::attitude_max_gradient_error, so its attitude is withheld.
TEST(StarPose, AFitTiltedAgainstTheOutlinesDisparityGradientIsNoAttitude) {
  const TestRig rig;
  const StereoCalibration calibration = rectify(station_rig_of(rig));
  const LocatorSettings settings = drawn_pair_settings();
  StereoStarLocator locator(calibration, settings);
  cv::RNG rng(20261204);
  int scenes = 0, aligned = 0, posed = 0;
  double worst_true = 0.0, worst_fit = 0.0, least_tilted = 1e9;
  for (double range : {1.0, 1.8, 2.6}) {
    for (int i = 0; i < 6; ++i) {
      const double tilt = rng.uniform(0.0, 20.0) * CV_PI / 180.0, axis = rng.uniform(0.0, 2 * CV_PI);
      cv::Matx33d R_LS;
      cv::Rodrigues(cv::Vec3d(std::cos(axis), std::sin(axis), 0.0) * tilt, R_LS);
      const cv::Vec3d t_L(rng.uniform(-0.1, 0.1), rng.uniform(-0.1, 0.1), range);
      const DrawnPair pair = draw_pair(rig, R_LS, t_L, rng);
      ++scenes;
      const StarFix fix = locator.locate(pair.left, pair.right);
      if (!fix.found || !fix.outline.valid) continue;
      ++aligned;
      const cv::Vec2d measured = fix.outline.gradient;
      worst_true = std::max(worst_true, cv::norm(plane_disparity_gradient(R_LS, t_L, calibration) - measured));
      if (!fix.pose.valid) continue;
      ++posed;
      worst_fit = std::max(worst_fit, fix.pose_gradient_error);
      // The same star tilted 50° further about the axis of its true tilt.
      cv::Matx33d R_more;
      cv::Rodrigues(cv::Vec3d(std::cos(axis), std::sin(axis), 0.0) * (50.0 * CV_PI / 180.0), R_more);
      least_tilted = std::min(least_tilted, cv::norm(plane_disparity_gradient(R_more * R_LS, t_L, calibration) - measured));
    }
  }
  std::printf("[vision] disparity gradient of the star's plane against the aligned outlines': %d scenes, %d aligned, "
              "%d poses; true plane within %.4f, fitted within %.4f, tilted 50° further at least %.4f px/px\n",
              scenes, aligned, posed, worst_true, worst_fit, least_tilted);
  EXPECT_EQ(aligned, scenes);
  EXPECT_EQ(posed, scenes);
  EXPECT_LT(worst_true, 0.5 * settings.attitude_max_gradient_error);
  EXPECT_LT(worst_fit, 0.5 * settings.attitude_max_gradient_error);
  EXPECT_GT(least_tilted, 2.0 * settings.attitude_max_gradient_error);
}

TEST(StarPose, RefitFromAStartOffRecoversThePoseAndDropsStrayPoints) {
  const TestRig rig;
  const StereoCalibration calibration = rectify(station_rig_of(rig));
  cv::Matx33d R_LS;
  cv::Rodrigues(cv::Vec3d(0.15, -0.12, 0.7), R_LS);  // tilted 11° about an in-plane axis, yawed 40°
  const cv::Vec3d t_L(0.2, -0.1, 1.5);
  // Edge points along the middle of each true edge, 0.02 px of noise across it; every eighth point is
  // 4 px off (an edge of texture or of a fault band found instead of the star's).
  const std::array<std::array<cv::Point2d, 8>, 2> star = rectified_corners(calibration, R_LS, t_L);
  cv::RNG rng(7);
  StarEdgePoints points;
  int count = 0;
  for (int view = 0; view < 2; ++view) {
    for (int k = 0; k < 8; ++k) {
      const cv::Point2d a = star[view][k], b = star[view][(k + 1) % 8];
      const cv::Point2d normal = cv::Point2d(-(b - a).y, (b - a).x) / cv::norm(b - a);
      for (int i = 0; i < 20; ++i) {
        const double across = ++count % 8 == 0 ? 4.0 : rng.gaussian(0.02);
        const cv::Point2d q = a + (0.15 + 0.7 * i / 19.0) * (b - a) + across * normal;
        points[view][k].emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
      }
    }
  }
  // The start: 2° off in attitude, 3 cm off in position, 4 % too large.
  StarPose start;
  start.valid = true;
  cv::Matx33d R_off;
  cv::Rodrigues(cv::Vec3d(0.035, 0.0, 0.0), R_off);
  start.R_CS = R_off * R_LS;
  start.t_C = t_L + cv::Vec3d(0.02, -0.01, 0.02);
  start.size_ratio = 1.04;
  start.rms_px = 0.8;
  const StarPose pose = refit_star_pose(start, points, calibration, StarPoseSettings{});
  ASSERT_TRUE(pose.valid);
  const cv::Vec3d n_true(R_LS(0, 2), R_LS(1, 2), R_LS(2, 2)), n_fit(pose.R_CS(0, 2), pose.R_CS(1, 2), pose.R_CS(2, 2));
  const double tilt_error = degrees(std::acos(std::clamp(n_true.dot(n_fit), -1.0, 1.0)));
  std::printf("[vision] refit from 2 deg, 3 cm, 4 %% off with 1 point in 8 stray: tilt %.4f deg, position %.2f mm, "
              "size %.4f, edge sigma %.3f px\n", tilt_error, 1e3 * cv::norm(pose.t_C - t_L), pose.size_ratio,
              pose.edge_sigma_px);
  // At 1.5 m a tilt of 0.1° changes the disparity across the star by 0.02 px: the noise's order.
  EXPECT_LT(tilt_error, 0.1);
  EXPECT_LT(cv::norm(pose.t_C - t_L), 0.002);
  EXPECT_NEAR(pose.size_ratio, 1.0, 0.005);
  EXPECT_DOUBLE_EQ(pose.rms_px, start.rms_px);
  // The stray points were dropped: the residual is the noise's (floored at min_edge_sigma_px).
  EXPECT_LT(pose.edge_sigma_px, 0.16);
}

// A star whose tip is cut by the left image's right edge (whole in the right view, which sees it a
// disparity further in), where the frame's outermost columns are as bright as the floor (as a capture
// device's edge often is): its outline stops short of the edge and passes the border filter; the fitted
// star reaches beyond the edge, so no fix. The same star 12 px further in is found.
TEST(StarPose, AStarCutByTheImageEdgeIsNotTakenWhenItsOutlineStopsShortOfTheEdge) {
  const TestRig rig;
  StereoStarLocator locator(rectify(station_rig_of(rig)), drawn_pair_settings());
  cv::Matx33d R_LS;
  cv::Rodrigues(cv::Vec3d(0.05, -0.04, 0.3), R_LS);
  // The star's right end in the left image, in pixels, for a centre at lateral offset x (metres).
  auto rightmost = [&](double x, double y) {
    std::vector<cv::Point2d> px;
    cv::Vec3d rvec;
    cv::Rodrigues(R_LS, rvec);
    cv::projectPoints(star_outline(), rvec, cv::Vec3d(x, y, 1.0), rig.K1, rig.D1, px);
    double m = -1e9;
    for (const cv::Point2d& p : px) m = std::max(m, p.x);
    return m;
  };
  auto centre_with_rightmost = [&](double target_px, double y) {
    double lo = 0.0, hi = 1.5;  // rightmost grows with x
    for (int i = 0; i < 60; ++i) (rightmost(0.5 * (lo + hi), y) < target_px ? lo : hi) = 0.5 * (lo + hi);
    return 0.5 * (lo + hi);
  };
  const int width = rig.size.width;
  int cut_found = 0, whole_found = 0, refused_at_edge = 0;
  cv::RNG rng(11);
  for (int i = 0; i < 6; ++i) {
    for (bool cut : {true, false}) {
      const double y = 0.05 * i - 0.12;
      const cv::Vec3d t_L(centre_with_rightmost(cut ? width + 1.0 : width - 13.0, y), y, 1.0);
      DrawnPair pair = draw_pair(rig, R_LS, t_L, rng);
      pair.left.colRange(width - 4, width).setTo(cv::Scalar(205));
      const StarFix fix = locator.locate(pair.left, pair.right);
      if (cut) {
        cut_found += fix.found ? 1 : 0;
        refused_at_edge += fix.refused != nullptr && std::strcmp(fix.refused, "fitted star beyond the image edge") == 0;
      } else {
        whole_found += fix.found ? 1 : 0;
      }
    }
  }
  std::printf("[vision] star cut by the left view's edge (outline short of it): %d of 6 taken, %d refused at "
              "the edge; 12 px inside: %d of 6 found\n", cut_found, refused_at_edge, whole_found);
  EXPECT_EQ(cut_found, 0);
  EXPECT_GE(refused_at_edge, 1);  // the case the rule is for reaches it
  EXPECT_EQ(whole_found, 6);
}

TEST(StarPose, AttitudeInBodyPicksTheTipNearestForwardAndQuaternionMatches) {
  // Level vehicle over a level star yawed by 100 deg: body forward is nearest the tip at 100 - 90 = 10 deg.
  const CameraMount mount = thesis_camera_mount();
  cv::Matx33d R_BS_true;
  cv::Rodrigues(cv::Vec3d(0, 0, 100.0 * CV_PI / 180.0), R_BS_true);
  const cv::Matx33d R_CS = mount.R_BC.t() * R_BS_true;
  const cv::Matx33d R_BS = star_attitude_in_body(mount.R_BC, R_CS);
  EXPECT_NEAR(std::atan2(R_BS(1, 0), R_BS(0, 0)), 10.0 * CV_PI / 180.0, 1e-9);
  const cv::Vec4d q = quaternion_from_rotation(R_BS);
  EXPECT_NEAR(q[0], std::cos(5.0 * CV_PI / 180.0), 1e-9);
  EXPECT_NEAR(q[3], std::sin(5.0 * CV_PI / 180.0), 1e-9);
  // Against OpenCV's Rodrigues on a general rotation.
  cv::Matx33d R;
  const cv::Vec3d w(0.3, -1.1, 2.2);
  cv::Rodrigues(w, R);
  const cv::Vec4d qr = quaternion_from_rotation(R);
  const double angle = cv::norm(w);
  const double sign = qr[0] >= 0 ? 1.0 : -1.0;
  EXPECT_NEAR(qr[0], sign * std::cos(angle / 2), 1e-9);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(qr[i + 1], sign * std::sin(angle / 2) * w[i] / angle, 1e-9);
}

TEST(StarPose, LandingTargetCarriesTheAttitudeAndItsCovarianceMessage) {
  const TestRig rig;
  cv::RNG rng(5);
  // Camera frame: the star's x axis at 30 deg from the image's x (towards its y). With the thesis mount
  // (camera x = body y, camera y = body −x) the star's tips lie at 30 + 90 k deg from body y, i.e. at
  // −60, 30, 120, 210 deg from body x: the tip nearest forward is at +30 deg.
  const LevelScene scene = level_scene(rig, 30.0 * CV_PI / 180.0, 1.2, rng);
  LocatorSettings settings;
  settings.detector.deinterlace = Deinterlace::kNone;  // drawn progressive
  StereoStarLocator locator(rectify(station_rig_of(rig)), settings);
  const StarFix fix = locator.locate(scene.left, scene.right);
  ASSERT_TRUE(fix.found);
  ASSERT_TRUE(fix.pose.valid);
  const CameraMount mount = thesis_camera_mount();
  const mavlink::LandingTarget target = landing_target(fix, mount, 123456);
  EXPECT_EQ(target.position_valid, 1);
  EXPECT_EQ(target.type, mavlink::kLandingTargetTypeVisionFiducial);
  // Level star, level vehicle: q is a yaw of +30 deg about body z (w first).
  EXPECT_NEAR(target.q[0], std::cos(15.0 * CV_PI / 180.0), 2e-3);
  EXPECT_NEAR(target.q[3], std::sin(15.0 * CV_PI / 180.0), 2e-3);
  EXPECT_NEAR(target.q[1], 0.0, 3e-3);
  EXPECT_NEAR(target.q[2], 0.0, 3e-3);
  // The covariance message, through the codec and a parser that knows the dialect.
  const mavlink::LandingTargetCovariance cov = landing_target_covariance(fix, mount, target.time_usec);
  mavlink::Sender sender(1, mavlink::kCompIdVisualInertialOdometry);
  uint8_t out[mavlink::max_frame_length<mavlink::LandingTargetCovariance>()];
  const size_t n = sender.encode(cov, out, sizeof out);
  ASSERT_GT(n, 0u);
  mavlink::Parser parser(mavlink::dialect_message_info);
  bool decoded = false;
  parser.feed(out, n, [&](const mavlink::Frame& frame) {
    mavlink::LandingTargetCovariance back;
    ASSERT_TRUE(mavlink::decode(frame, back));
    decoded = true;
    EXPECT_EQ(back.time_usec, 123456u);
    EXPECT_EQ(back.attitude_valid, 1);
    for (int i = 0; i < 6; ++i) {
      EXPECT_EQ(back.attitude_covariance[i], cov.attitude_covariance[i]);
      EXPECT_EQ(back.position_covariance[i], cov.position_covariance[i]);
    }
  });
  EXPECT_TRUE(decoded);
  // Diagonals positive: variances about body x, y, z and of x, y, z.
  for (int i : {0, 3, 5}) {
    EXPECT_GT(cov.attitude_covariance[i], 0.0f);
    EXPECT_GT(cov.position_covariance[i], 0.0f);
  }
  // The attitude sigma is far below the 0.5 deg the tilt is checked to elsewhere, and not zero.
  EXPECT_LT(std::sqrt(cov.attitude_covariance[0]), 0.01);
  // The wire layout mavlink-mappings-gen computed from link/mavlink/quad_pose.xml: time_usec at 0,
  // position_covariance at 8, attitude_covariance at 32, target_num at 56, attitude_valid at 57.
  const uint8_t* payload = out + mavlink::kHeaderLength;
  float first_attitude = 0.0f;
  std::memcpy(&first_attitude, payload + 32, 4);
  EXPECT_EQ(first_attitude, cov.attitude_covariance[0]);
}

TEST(StarPose, DetectPrintsTheAttitude) {
  const TestRig rig;
  cv::RNG rng(6);
  const LevelScene scene = level_scene(rig, 0.3, 1.4, rng);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("quad_pose_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  save_calibration(rectify(station_rig_of(rig)), (dir / "calib.yaml").string());
  cv::imwrite((dir / "l.png").string(), scene.left);
  cv::imwrite((dir / "r.png").string(), scene.right);
  const std::string command = std::string(VISION_STATION_EXE) + " detect --calib " + (dir / "calib.yaml").string() +
                              " --left " + (dir / "l.png").string() + " --right " + (dir / "r.png").string() + " > " +
                              (dir / "out.json").string();
  ASSERT_EQ(std::system(command.c_str()), 0);
  std::ifstream in(dir / "out.json");
  std::string json((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::filesystem::remove_all(dir);
  std::printf("[vision] detect: %s", json.c_str());
  EXPECT_NE(json.find("\"q\":["), std::string::npos) << json;
  EXPECT_NE(json.find("\"attitude_sigma_rad\":["), std::string::npos) << json;
  // A level star below a level vehicle: tilt near zero.
  const size_t at = json.find("\"tilt_deg\":");
  ASSERT_NE(at, std::string::npos);
  EXPECT_LT(std::stod(json.substr(at + 11)), 0.3) << json;
}

}  // namespace
}  // namespace quad::vision
