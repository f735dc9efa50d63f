// The robust detector's parts: the radial-profile shape test on outlines built here (the star and each
// decoy, tilted, blurred), the rectification table against the exact point rectifier, and the field
// (deinterlace) geometry against the full frame, and an ROI search against the full frame's.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "quad/vision/star_detector.h"
#include "quad/vision/star_shape.h"
#include "quad/vision/rectify_table.h"
#include "star_scenes.h"

namespace quad::vision {
namespace {

// A star-shaped outline r(θ) sampled densely, optionally stretched by an affine map (a tilted view).
std::vector<cv::Point2f> polygon(const std::vector<cv::Point2d>& vertices, cv::Matx22d affine = cv::Matx22d::eye()) {
  std::vector<cv::Point2f> out;
  for (size_t i = 0; i < vertices.size(); ++i) {
    const cv::Point2d a = vertices[i], b = vertices[(i + 1) % vertices.size()];
    for (int k = 0; k < 10; ++k) {
      const cv::Point2d p = a + (b - a) * (k / 10.0);
      const cv::Vec2d q = affine * cv::Vec2d(p.x, p.y);
      out.emplace_back(static_cast<float>(300 + q[0]), static_cast<float>(300 + q[1]));
    }
  }
  return out;
}

std::vector<cv::Point2d> star(int points, double outer, double inner, double yaw) {
  std::vector<cv::Point2d> v;
  for (int i = 0; i < 2 * points; ++i) {
    const double r = i % 2 == 0 ? outer : inner, a = yaw + i * CV_PI / points;
    v.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  return v;
}

std::vector<cv::Point2d> regular(int n, double r, double yaw) {
  std::vector<cv::Point2d> v;
  for (int i = 0; i < n; ++i) v.emplace_back(r * std::cos(yaw + 2 * CV_PI * i / n), r * std::sin(yaw + 2 * CV_PI * i / n));
  return v;
}

std::vector<cv::Point2d> cross(double arm, double half_width) {
  const double a = arm, w = half_width;
  return {{w, -w}, {a, -w}, {a, w}, {w, w}, {w, a}, {-w, a}, {-w, w}, {-a, w}, {-a, -w}, {-w, -w}, {-w, -a}, {w, -a}};
}

// The outline of a shape drawn filled, blurred by `blur` px and thresholded at mid-level (what a blurred
// camera image gives).
std::vector<cv::Point2f> blurred(const std::vector<cv::Point2f>& outline, double blur) {
  cv::Mat img(600, 600, CV_8U, cv::Scalar(0));
  std::vector<cv::Point> pts(outline.begin(), outline.end());
  cv::fillPoly(img, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255), cv::LINE_AA);
  cv::GaussianBlur(img, img, cv::Size(), blur);
  cv::Mat bin = img > 127;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(bin, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  EXPECT_EQ(contours.size(), 1u);
  return std::vector<cv::Point2f>(contours[0].begin(), contours[0].end());
}

TEST(StarShapeTest, AcceptsTheStarTiltedRotatedAndBlurred) {
  const StarShapeTest test(0.4, StarShapeLimits{});
  for (double yaw : {0.0, 0.3, 1.1}) {
    for (const cv::Matx22d& view : {cv::Matx22d::eye(), cv::Matx22d(1.0, 0.2, 0.0, 0.6), cv::Matx22d(0.5, 0.0, 0.1, 1.0)}) {
      for (double sigma : {0.0, 1.5, 3.0}) {
        const std::vector<cv::Point2f> outline = polygon(star(4, 60, 24, yaw), view);
        const StarShapeScore s = test.score(sigma > 0 ? blurred(outline, sigma) : outline);
        EXPECT_TRUE(s.is_star) << "yaw " << yaw << " blur " << sigma << " rms " << s.profile_rms << " fourfold "
                               << s.fourfold << " other " << s.other_harmonic << " solidity " << s.solidity;
      }
    }
  }
}

TEST(StarShapeTest, RejectsEveryDecoy) {
  const StarShapeTest test(0.4, StarShapeLimits{});
  const std::vector<std::pair<const char*, std::vector<cv::Point2d>>> decoys{
      {"five-pointed star", star(5, 60, 26, 0.2)}, {"five-pointed star, fat", star(5, 60, 30, 0.0)},
      {"square", regular(4, 60, 0.3)}, {"circle", regular(90, 50, 0.0)}, {"cross", cross(60, 10)},
      {"cross, thick", cross(60, 16)}, {"triangle", regular(3, 60, 0.0)}, {"six-pointed star", star(6, 60, 30, 0.0)}};
  for (const auto& [name, shape] : decoys) {
    for (double sigma : {0.0, 2.0}) {
      const std::vector<cv::Point2f> outline = polygon(shape, cv::Matx22d(1.0, 0.1, 0.0, 0.85));
      const StarShapeScore s = test.score(sigma > 0 ? blurred(outline, sigma) : outline);
      EXPECT_FALSE(s.is_star) << name << " blur " << sigma << " rms " << s.profile_rms << " fourfold " << s.fourfold
                              << " other " << s.other_harmonic << " solidity " << s.solidity;
    }
  }
}

TEST(RectifyTableTest, MatchesTheExactRectifierWithinAHundredthOfAPixel) {
  const StereoCalibration calibration = rectify(thesis_stereo_rig());
  for (int camera : {0, 1}) {
    const PointRectifier exact(calibration, camera, 40);
    const RectifyTable table(exact, calibration.rig.image_size);
    cv::RNG rng(5);
    double worst = 0.0;
    const cv::Matx33d& K = camera == 0 ? calibration.rig.left.K : calibration.rig.right.K;
    for (int i = 0; i < 2000; ++i) {
      // Inside the lens model's valid field (docs/vision_station.md: the polynomial folds back near the
      // corners): within 260 px of the principal point.
      const cv::Point p(rng.uniform(0, 728), rng.uniform(0, 488));
      if (std::hypot(p.x - K(0, 2), p.y - K(1, 2)) > 260.0) continue;
      std::vector<cv::Point2f> e;
      exact.apply({p}, e);
      worst = std::max(worst, cv::norm(table.map(cv::Point2f(p)) - e[0]));
    }
    EXPECT_LT(worst, 0.01) << "camera " << camera;
  }
}

// The field view (every other row, rows mapped back ×2) measures the same rectified centroid as the full
// frame on a progressive image: median difference below 0.2 px, none above 0.6 px (half the rows are
// missing); the blend view likewise. A wrong row mapping (×1, or off by a row) moves it by pixels.
TEST(DeinterlaceTest, FieldAndBlendKeepTheFrameGeometry) {
  const StereoRig rig = thesis_stereo_rig();
  const StereoCalibration calibration = rectify(rig);
  cv::RNG rng(11);
  int compared = 0;
  std::vector<double> field, blend;
  for (int scene_index = 0; scene_index < 40 && compared < 12; ++scene_index) {
    const auto scene = testing::random_star_scene(rig, rng, testing::StarSceneRanges{});
    if (!scene) continue;
    cv::Point2d centroid[3];
    bool found = true;
    const Deinterlace modes[3] = {Deinterlace::kNone, Deinterlace::kField, Deinterlace::kBlend};
    for (int m = 0; m < 3; ++m) {
      DetectorSettings settings;
      settings.deinterlace = modes[m];
      StarDetector detector(settings, PointRectifier(calibration, 0, 40));
      const std::vector<StarCandidate> c = detector.detect(scene->left, cv::Rect());
      found = found && !c.empty();
      if (!c.empty()) centroid[m] = c[0].centroid;
    }
    if (!found) continue;
    ++compared;
    field.push_back(cv::norm(centroid[1] - centroid[0]));
    blend.push_back(cv::norm(centroid[2] - centroid[0]));
    EXPECT_LT(field.back(), 0.6) << "field vs frame, scene " << scene_index;
    EXPECT_LT(blend.back(), 0.6) << "blend vs frame, scene " << scene_index;
  }
  ASSERT_GE(compared, 10);
  std::sort(field.begin(), field.end());
  std::sort(blend.begin(), blend.end());
  std::printf("centroid difference to the frame, median: field %.3f px, blend %.3f px\n", field[field.size() / 2],
              blend[blend.size() / 2]);
  EXPECT_LT(field[field.size() / 2], 0.2);
  EXPECT_LT(blend[blend.size() / 2], 0.2);
}

// An ROI search measures the floor over the ROI grown by the floor's reach on the full frame's grid, so
// at the full frame's contrast level it cuts the star exactly as the full-frame search does: the same
// outline, pixel for pixel, for each deinterlace mode and ROIs at any offset. (Measuring the floor on the
// ROI alone takes the brightest part of a small ROI as the floor and cuts the star larger.) These scenes
// have no lost-sync bands: the band repair's statistics are the floor region's, not the frame's.
TEST(RobustRoiTest, AnRoiSearchCutsTheStarAsTheFullFrameDoes) {
  const StereoRig rig = thesis_stereo_rig();
  const StereoCalibration calibration = rectify(rig);
  cv::RNG rng(23);
  int compared = 0;
  for (int scene_index = 0; scene_index < 40 && compared < 30; ++scene_index) {
    const auto scene = testing::random_star_scene(rig, rng, testing::StarSceneRanges{});
    if (!scene) continue;
    for (Deinterlace mode : {Deinterlace::kNone, Deinterlace::kField, Deinterlace::kBlend}) {
      DetectorSettings settings;
      settings.deinterlace = mode;
      StarDetector detector(settings, PointRectifier(calibration, 0, 40));
      const std::vector<StarCandidate> full = detector.detect(scene->left, cv::Rect());
      if (full.empty()) continue;
      const double level = detector.last_threshold_ratio();
      const cv::Rect box = full[0].box;
      const int margin = 20 + rng.uniform(0, 9);  // an ROI not on the 8-pixel grid
      const cv::Rect roi(box.x - margin, box.y - margin - rng.uniform(0, 3), box.width + 2 * margin + 3, box.height + 2 * margin);
      const std::vector<StarCandidate> within = detector.detect(scene->left, roi, nullptr, level);
      ASSERT_FALSE(within.empty()) << "scene " << scene_index << " mode " << to_string(mode);
      EXPECT_EQ(within[0].contour, full[0].contour) << "scene " << scene_index << " mode " << to_string(mode);
      EXPECT_EQ(within[0].centroid, full[0].centroid) << "scene " << scene_index << " mode " << to_string(mode);
      ++compared;
    }
  }
  EXPECT_GE(compared, 30);
}

}  // namespace
}  // namespace quad::vision
