// Star detection and stereo fix on scenes rendered through the thesis camera model (issue 7 figures):
// median 3D error ≤ 1 % of the range, 95th percentile ≤ 2 %, detection ≥ 99 % with the whole star in
// both views; no false fix in distractor scenes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <vector>

#include "quad/vision/stereo_locator.h"
#include "star_scenes.h"

namespace quad::vision {
namespace {

using testing::FloorShape;
using testing::RenderOptions;
using testing::StarScene;
using testing::StarSceneRanges;

double percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  return v[i];
}

class StarFixTest : public ::testing::Test {
 protected:
  StereoRig rig = thesis_stereo_rig();
  StereoCalibration calibration = rectify(rig);
};

TEST_F(StarFixTest, AccuracyAndDetectionRateOverHeightsAndTilts) {
  constexpr int kScenes = 300;
  cv::RNG rng(20261122);
  StereoStarLocator locator(calibration, LocatorSettings{});
  std::vector<double> relative_errors;
  std::vector<double> sigma_ratio;  // |error| / predicted σ along the range, for the uncertainty check
  int found = 0, generated = 0;
  double min_height = 1e9, max_height = 0.0, max_tilt = 0.0;
  for (int i = 0; i < kScenes; ++i) {
    const std::optional<StarScene> scene = testing::random_star_scene(rig, rng, StarSceneRanges{});
    ASSERT_TRUE(scene.has_value()) << "scene generator could not place the star in both views";
    ++generated;
    min_height = std::min(min_height, scene->height);
    max_height = std::max(max_height, scene->height);
    max_tilt = std::max(max_tilt, scene->tilt);
    locator.reset_tracking();  // independent scenes
    const StarFix fix = locator.locate(scene->left, scene->right);
    if (!fix.found) continue;
    ++found;
    const double range = cv::norm(scene->truth_left);
    relative_errors.push_back(cv::norm(fix.p_left - scene->truth_left) / range);
    sigma_ratio.push_back(std::fabs(fix.p_left[2] - scene->truth_left[2]) / fix.sigma_left[2]);
  }
  const double rate = static_cast<double>(found) / generated;
  const double median = percentile(relative_errors, 0.5);
  const double p95 = percentile(relative_errors, 0.95);
  std::printf("[vision] %d scenes, heights %.2f-%.2f m, tilts up to %.1f deg: detection %.2f %%, 3D error "
              "median %.3f %% p95 %.3f %% max %.3f %% of range; |dz|/sigma_z median %.2f\n",
              generated, min_height, max_height, max_tilt * 180.0 / CV_PI, 100.0 * rate, 100.0 * median,
              100.0 * p95, 100.0 * percentile(relative_errors, 1.0), percentile(sigma_ratio, 0.5));
  EXPECT_GE(rate, 0.99);
  EXPECT_LE(median, 0.01);
  EXPECT_LE(p95, 0.02);
  EXPECT_LT(max_height - min_height, 2.2);  // the heights really span the range
  EXPECT_GT(max_height - min_height, 1.6);
  // The reported σ is not off by an order of magnitude in either direction.
  EXPECT_GT(percentile(sigma_ratio, 0.5), 0.1);
  EXPECT_LT(percentile(sigma_ratio, 0.5), 5.0);
}

}  // namespace
}  // namespace quad::vision
