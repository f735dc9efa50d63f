// The star's attitude from both views, on images this test draws itself: its own rig (not the thesis
// rig), its own star outline, projected with cv::projectPoints and filled 4x supersampled; none of the
// station's rig, lens, star or renderer code draws them. Tilt error = angle between the estimated and
// the true star normal; median <= 0.2 deg over all ranges and at each range up to 1.5 m (reported per
// range), and the reported attitude sigma consistent with the errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

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
  std::vector<cv::Point> polygon;
  for (const cv::Point2d& p : projected) {
    polygon.emplace_back(cvRound((p.x + 0.5) * kSuper - 0.5), cvRound((p.y + 0.5) * kSuper - 0.5));
  }
  cv::Mat big(size.height * kSuper, size.width * kSuper, CV_8UC1, cv::Scalar(205));
  cv::fillPoly(big, std::vector<std::vector<cv::Point>>{polygon}, cv::Scalar(35));
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

TEST(StarPose, TiltFromIndependentlyDrawnStereoPairs) {
  const TestRig rig;
  StereoRig station_rig;
  station_rig.image_size = rig.size;
  station_rig.left = CameraIntrinsics{rig.K1, rig.D1};
  station_rig.right = CameraIntrinsics{rig.K2, rig.D2};
  cv::Rodrigues(rig.r_rel, station_rig.R);
  station_rig.T = rig.T;
  const StereoCalibration calibration = rectify(station_rig);
  LocatorSettings settings;
  settings.track_roi = false;
  StereoStarLocator locator(calibration, settings);

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
      const cv::Matx33d R_RL = station_rig.R;
      const cv::Mat left = draw(rig.K1, rig.D1, R_LS, t_L, rig.size, rng);
      const cv::Mat right = draw(rig.K2, rig.D2, R_RL * R_LS, R_RL * t_L + rig.T, rig.size, rng);
      ++drawn;
      const StarFix fix = locator.locate(left, right);
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
    // optimistic nor far too pessimistic.
    EXPECT_GT(median(normalised[range]), 0.4) << "range " << range;
    EXPECT_LT(median(normalised[range]), 2.5) << "range " << range;
  }
  std::printf("[vision]   all ranges: tilt error median %.3f deg; pose %.0f us of %.0f us per pair (mean, shared CPU)\n",
              median(all), pose_us / std::max(posed, 1), total_us / std::max(posed, 1));
  EXPECT_LE(median(all), 0.2);
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

}  // namespace
}  // namespace quad::vision
