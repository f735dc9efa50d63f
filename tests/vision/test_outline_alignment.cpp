// align_outlines on outlines the test draws itself: a four-pointed star (tips 40 px, inner corners at
// 0.4 of that), sampled densely along its edges, the right copy shifted by a known disparity and row
// offset. A blob grown onto one tip of the right view moves that view's area centroid by about a pixel;
// the alignment must still give the shift within 0.05 px. A five-pointed star against a four-pointed one
// must not align well (large residual). A tilted star seen by two rectified cameras (projected by
// cv::projectPoints): its disparity varies across the outline, and the alignment must give the one of
// its centre.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/outline_alignment.h"

namespace quad::vision {
namespace {

std::vector<cv::Point2f> star_outline(int points, double tip, double inner, cv::Point2d centre, double phase,
                                      double step_px = 0.5) {
  std::vector<cv::Point2d> vertices;
  for (int k = 0; k < 2 * points; ++k) {
    const double r = k % 2 == 0 ? tip : inner;
    const double a = phase + CV_PI * k / points;
    vertices.emplace_back(centre.x + r * std::cos(a), centre.y + r * std::sin(a));
  }
  std::vector<cv::Point2f> outline;
  for (size_t k = 0; k < vertices.size(); ++k) {
    const cv::Point2d a = vertices[k], b = vertices[(k + 1) % vertices.size()];
    const int n = static_cast<int>(std::ceil(cv::norm(b - a) / step_px));
    for (int i = 0; i < n; ++i) outline.emplace_back(a + (b - a) * (static_cast<double>(i) / n));
  }
  return outline;
}

cv::Point2d centroid(const std::vector<cv::Point2f>& outline) {
  const cv::Moments m = cv::moments(outline);
  return {m.m10 / m.m00, m.m01 / m.m00};
}

TEST(OutlineAlignment, RecoversTheShiftDespiteADefectOnOneView) {
  const cv::Point2d shift(23.4, 0.3);
  const std::vector<cv::Point2f> left = star_outline(4, 40.0, 16.0, {300.0, 200.0}, 0.3);
  std::vector<cv::Point2f> right = star_outline(4, 40.0, 16.0, cv::Point2d(300.0, 200.0) - shift, 0.3);
  // A dark blob merged with the rightmost tip of the right view: the outline bulges out around it.
  const cv::Point2d centre = cv::Point2d(300.0, 200.0) - shift;
  const cv::Point2d tip = centre + 40.0 * cv::Point2d(std::cos(0.3), std::sin(0.3));
  for (cv::Point2f& p : right) {
    const double d = cv::norm(cv::Point2d(p) - tip);
    const cv::Point2d out = (cv::Point2d(p) - centre) / cv::norm(cv::Point2d(p) - centre);
    if (d < 14.0) p = cv::Point2f(cv::Point2d(p) + out * (6.0 * (14.0 - d) / 14.0));
  }
  const cv::Point2d centroid_shift = centroid(left) - centroid(right);
  ASSERT_GT(std::fabs(centroid_shift.x - shift.x), 0.4) << "the defect must move the centroid";
  const OutlineAlignment a = align_outlines(left, right, centroid_shift);
  ASSERT_TRUE(a.valid);
  EXPECT_NEAR(a.shift.x, shift.x, 0.05);
  EXPECT_NEAR(a.shift.y, shift.y, 0.05);
  EXPECT_LT(a.residual_px, 0.2);
  std::printf("[vision] outline alignment: centroid shift error %.3f px, aligned %.4f px\n",
              centroid_shift.x - shift.x, a.shift.x - shift.x);
}

TEST(OutlineAlignment, ExactCopiesAlignExactly) {
  const std::vector<cv::Point2f> left = star_outline(4, 30.0, 12.0, {100.0, 120.0}, 1.1);
  const std::vector<cv::Point2f> right = star_outline(4, 30.0, 12.0, {80.5, 119.25}, 1.1);
  const OutlineAlignment a = align_outlines(left, right, {18.0, 1.5});
  ASSERT_TRUE(a.valid);
  EXPECT_NEAR(a.shift.x, 19.5, 0.02);
  EXPECT_NEAR(a.shift.y, 0.75, 0.02);
}

TEST(OutlineAlignment, ATiltedStarGivesTheDisparityOfItsCentre) {
  // A 0.2 m star 0.9 m away, 0.25 m off the axis, its plane turned 40° about an axis between x and y:
  // the disparity changes by several pixels from tip to tip.
  const double f = 450.0, baseline = 0.12;
  const cv::Point3d centre(0.25, -0.1, 0.9);
  const cv::Matx33d turn = [] {
    cv::Matx33d R;
    cv::Rodrigues(cv::Vec3d(0.5, 0.45, 0.2) * (40.0 * CV_PI / 180.0 / std::hypot(0.5, 0.45, 0.2)), R);
    return R;
  }();
  std::vector<cv::Point3d> star;
  for (const cv::Point2f& p : star_outline(4, 0.2, 0.08, {0.0, 0.0}, 0.4, 0.002)) {
    star.push_back(centre + cv::Point3d(turn * cv::Vec3d(p.x, p.y, 0.0)));
  }
  const cv::Matx33d K(f, 0.0, 360.0, 0.0, f, 240.0, 0.0, 0.0, 1.0);
  auto project = [&](const std::vector<cv::Point3d>& points, double camera_x) {
    std::vector<cv::Point2d> image;
    cv::projectPoints(points, cv::Vec3d(0.0, 0.0, 0.0), cv::Vec3d(-camera_x, 0.0, 0.0), K, cv::noArray(), image);
    return std::vector<cv::Point2f>(image.begin(), image.end());
  };
  const std::vector<cv::Point2f> left = project(star, 0.0), right = project(star, baseline);
  const cv::Point2f left_centre = project({centre}, 0.0)[0];
  const double truth = f * baseline / centre.z;
  const cv::Point2d centroid_shift = centroid(left) - centroid(right);
  const OutlineAlignment a = align_outlines(left, right, centroid_shift);
  ASSERT_TRUE(a.valid);
  EXPECT_NEAR(a.shift_at(left_centre).x, truth, 0.02);
  EXPECT_NEAR(a.shift_at(left_centre).y, 0.0, 0.02);
  EXPECT_LT(a.residual_px, 0.05);
  EXPECT_GT(std::fabs(a.gradient[0]) + std::fabs(a.gradient[1]), 0.01) << "the test must tilt the star";
  std::printf("[vision] tilted star: disparity %.3f px, centroids' %.3f px, aligned %.3f px (gradient %.4f %.4f)\n",
              truth, centroid_shift.x, a.shift_at(left_centre).x, a.gradient[0], a.gradient[1]);
}

TEST(OutlineAlignment, DifferentShapesLeaveALargeResidual) {
  const std::vector<cv::Point2f> left = star_outline(4, 40.0, 16.0, {300.0, 200.0}, 0.0);
  const std::vector<cv::Point2f> right = star_outline(5, 40.0, 16.0, {280.0, 200.0}, 0.0);
  const OutlineAlignment a = align_outlines(left, right, {20.0, 0.0});
  EXPECT_TRUE(!a.valid || a.residual_px > 1.0);
}

TEST(OutlineAlignment, TooFewPointsIsNoAlignment) {
  const std::vector<cv::Point2f> few(10, cv::Point2f(1.0f, 2.0f));
  EXPECT_FALSE(align_outlines(few, few, {0.0, 0.0}).valid);
}

}  // namespace
}  // namespace quad::vision
