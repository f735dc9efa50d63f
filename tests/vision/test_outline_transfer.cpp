// Outline transfer (LocatorSettings::outline_transfer, outline_transfer.h): a star whose outline is lost
// in one view (merged with a dark strip that runs to the image's edge, so no contour of its shape is
// left there) is found from the other view's outline, and so is a star whose outline in one view is a
// near miss that pairs but does not lay onto the other's, and a star lost in the left view while another
// left candidate placed the right view's search elsewhere; a star cut by the image's edge in one view is
// never taken, although most of its outline is there to match.
#include <string>

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "quad/vision/outline_transfer.h"
#include "quad/vision/star_pose.h"
#include "quad/vision/stereo_locator.h"
#include "star_scenes.h"

namespace quad::vision {
namespace {

class OutlineTransferTest : public ::testing::Test {
 protected:
  StarFix locate(const cv::Mat& left, const cv::Mat& right, bool transfer) const {
    LocatorSettings settings;
    settings.outline_transfer = transfer;
    StereoStarLocator locator(calibration, settings);
    return locator.locate(left, right);
  }

  // The rectified sub-pixel edges of a view's first passing star (as the locator takes them).
  std::vector<cv::Point2f> star_edges(const cv::Mat& gray, int camera, StarCandidate& star) const {
    StarDetector detector(DetectorSettings{}, PointRectifier(calibration, camera, 40));
    const std::vector<StarCandidate> found = detector.detect(gray, cv::Rect());
    if (found.empty()) return {};
    star = found.front();
    const NearRectifier view(calibration, camera);
    const std::vector<cv::Point2f> raw = subpixel_edges(gray, star.contour);
    std::vector<cv::Point2f> edges;
    for (size_t i = 0; i < raw.size(); ++i) edges.emplace_back(view.rectified(raw[i], star.rectified[i]));
    return edges;
  }

  StereoRig rig = thesis_stereo_rig();
  StereoCalibration calibration = rectify(rig);
};

TEST_F(OutlineTransferTest, AStarMergedWithAStripToTheEdgeIsFoundByTheOtherViewsOutline) {
  cv::RNG rng(7);
  testing::StarSceneRanges ranges;
  ranges.min_height = 1.2;
  ranges.max_height = 1.8;
  int scenes = 0, strict_found = 0, transferred_found = 0;
  double worst = 0.0;
  for (int k = 0; k < 6; ++k) {
    auto scene = testing::random_star_scene(rig, rng, ranges);
    ASSERT_TRUE(scene);
    StarCandidate right_star;
    ASSERT_FALSE(star_edges(scene->right, 1, right_star).empty());
    // A strip as dark as the star's core from its centre through its lowest point to the bottom edge:
    // the star's outline now runs into the image's edge.
    cv::Point2d centre(0.0, 0.0), lowest(0.0, -1.0);
    for (const cv::Point& p : right_star.contour) {
      centre += cv::Point2d(p);
      if (p.y > lowest.y) lowest = cv::Point2d(p);
    }
    centre *= 1.0 / static_cast<double>(right_star.contour.size());
    cv::Mat right = scene->right.clone();
    const cv::Scalar dark = cv::mean(scene->right, [&] {
      cv::Mat mask = cv::Mat::zeros(right.size(), CV_8UC1);
      cv::circle(mask, centre, 3, cv::Scalar(255), cv::FILLED);
      return mask;
    }());
    const int width = std::max(6, right_star.box.width / 10);
    cv::line(right, lowest, cv::Point2d(lowest.x, right.rows + 10.0), dark, width, cv::LINE_AA);
    ++scenes;
    const StarFix strict = locate(scene->left, right, false);
    const StarFix transferred = locate(scene->left, right, true);
    strict_found += strict.found;
    transferred_found += transferred.found;
    if (transferred.found) {
      EXPECT_TRUE(transferred.transferred);
      worst = std::max(worst, cv::norm(transferred.p_left - scene->truth_left) / cv::norm(scene->truth_left));
    }
  }
  std::printf("[vision] star merged with a strip to the edge in the right view: %d scenes, found %d without "
              "outline transfer, %d with it (worst error %.2f %% of the range)\n",
              scenes, strict_found, transferred_found, 100.0 * worst);
  EXPECT_EQ(strict_found, 0) << "the strip must cost the star its outline in the right view";
  EXPECT_EQ(transferred_found, scenes);
  EXPECT_LT(worst, 0.02);
}

TEST_F(OutlineTransferTest, ANearMissWhoseOutlineDoesNotAlignGivesWayToTheOtherViewsOutline) {
  // A dark stub hanging from the star's lowest tip in the right view: the outline there fails the shape
  // test but stays a near miss, which pairs with the left star and is then refused because the two
  // outlines do not lay onto each other. The left star's outline, sought in the right view, finds the
  // star's own edges there.
  cv::RNG rng(5);
  testing::StarSceneRanges ranges;
  ranges.min_height = 1.0;
  ranges.max_height = 1.6;
  int scenes = 0, found = 0;
  double worst = 0.0;
  for (int k = 0; k < 60 && scenes < 4; ++k) {
    auto scene = testing::random_star_scene(rig, rng, ranges);
    ASSERT_TRUE(scene);
    StarCandidate right_star;
    if (star_edges(scene->right, 1, right_star).empty()) continue;
    cv::Point2d lowest(0.0, -1.0);
    for (const cv::Point& p : right_star.contour) {
      if (p.y > lowest.y) lowest = cv::Point2d(p);
    }
    cv::Mat right = scene->right.clone();
    const double length = 0.35 * right_star.box.height;
    const int width = std::max(4, right_star.box.width / 12);
    cv::line(right, lowest, lowest + cv::Point2d(0.3 * length, length), cv::Scalar(30), width, cv::LINE_AA);
    const StarFix without = locate(scene->left, right, false);
    if (without.refused == nullptr || std::string(without.refused) != "guided outlines misaligned") continue;
    ++scenes;
    const StarFix fix = locate(scene->left, right, true);
    found += fix.found;
    if (fix.found) {
      EXPECT_TRUE(fix.transferred);
      worst = std::max(worst, cv::norm(fix.p_left - scene->truth_left) / cv::norm(scene->truth_left));
    }
  }
  std::printf("[vision] near miss refused as misaligned in the right view: %d scenes, found %d by outline "
              "transfer (worst error %.2f %% of the range)\n", scenes, found, 100.0 * worst);
  ASSERT_GE(scenes, 3) << "the stub must leave a near miss that pairs and is refused";
  EXPECT_EQ(found, scenes);
  EXPECT_LT(worst, 0.02);
}

TEST_F(OutlineTransferTest, AStarLostInTheLeftViewIsFoundWhenTheLeftCandidatePlacedTheRightSearchElsewhere) {
  // The left view: the star merged with a strip to the image's edge, and a star-shaped blot far from it
  // that passes the shape test, so the right view is searched only where the blot could appear. The
  // blot has no counterpart in the right view; the star, whole there, is found once the right view is
  // searched whole and its outline sought in the left view.
  cv::RNG rng(9);
  testing::StarSceneRanges ranges;
  ranges.min_height = 1.2;
  ranges.max_height = 1.8;
  int scenes = 0, found = 0;
  double worst = 0.0;
  for (int k = 0; k < 40 && scenes < 4; ++k) {
    auto scene = testing::random_star_scene(rig, rng, ranges);
    ASSERT_TRUE(scene);
    StarCandidate left_star;
    if (star_edges(scene->left, 0, left_star).empty()) continue;
    cv::Mat left = scene->left.clone();
    // The blot: the star's own outline moved half a frame across and a third of a frame down or up.
    const cv::Point shift(left_star.box.x + left_star.box.width / 2 < left.cols / 2 ? left.cols / 2 : -left.cols / 2,
                          left_star.box.y + left_star.box.height / 2 < left.rows / 2 ? left.rows / 3 : -left.rows / 3);
    std::vector<cv::Point> blot;
    for (const cv::Point& p : left_star.contour) blot.push_back(p + shift);
    const cv::Rect frame(cv::Point(8, 8), left.size() - cv::Size(16, 16));
    if ((cv::boundingRect(blot) & frame) != cv::boundingRect(blot)) continue;
    const cv::Scalar dark = cv::mean(scene->left, [&] {
      cv::Mat mask = cv::Mat::zeros(left.size(), CV_8UC1);
      cv::fillPoly(mask, std::vector<std::vector<cv::Point>>{left_star.contour}, cv::Scalar(255));
      cv::erode(mask, mask, cv::Mat(), cv::Point(-1, -1), 2);
      return mask;
    }());
    cv::fillPoly(left, std::vector<std::vector<cv::Point>>{blot}, dark, cv::LINE_AA);
    cv::Point2d lowest(0.0, -1.0);
    for (const cv::Point& p : left_star.contour) {
      if (p.y > lowest.y) lowest = cv::Point2d(p);
    }
    const int width = std::max(6, left_star.box.width / 10);
    cv::line(left, lowest, cv::Point2d(lowest.x, left.rows + 10.0), dark, width, cv::LINE_AA);
    const StarFix without = locate(left, scene->right, false);
    if (without.found) continue;  // the blot's window held the star after all
    ++scenes;
    const StarFix fix = locate(left, scene->right, true);
    found += fix.found;
    if (fix.found) {
      EXPECT_TRUE(fix.transferred);
      worst = std::max(worst, cv::norm(fix.p_left - scene->truth_left) / cv::norm(scene->truth_left));
    }
  }
  std::printf("[vision] star lost in the left view, a blot placing the right search elsewhere: %d scenes, "
              "found %d by outline transfer from the whole right view (worst error %.2f %% of the range)\n",
              scenes, found, 100.0 * worst);
  ASSERT_GE(scenes, 3);
  EXPECT_EQ(found, scenes);
  EXPECT_LT(worst, 0.02);
}

TEST_F(OutlineTransferTest, AStarCutByTheEdgeInTheOtherViewIsNotTaken) {
  // Poses that put the star wholly inside the left view and 4-14 px across the right view's left edge
  // (the right camera sees it a disparity farther left).
  cv::RNG rng(11);
  const std::vector<cv::Point2d> star = star_vertices(StarShape{});
  int scenes = 0, matched_without_edge_rule = 0, fixes = 0;
  for (int k = 0; k < 4000 && scenes < 4; ++k) {
    const double height = rng.uniform(1.0, 1.6);
    const cv::Point2d ray(rng.uniform(-0.88, -0.72), rng.uniform(0.0, 0.3));
    const testing::Pose left_pose = testing::camera_pose(height, rng.uniform(0.0, 0.2), rng.uniform(0.0, 2.0 * CV_PI),
                                                         rng.uniform(0.0, CV_PI / 2.0), ray, cv::Point2d(0, 0));
    const testing::Pose right_pose = testing::right_pose(rig, left_pose);
    if (!testing::fully_visible(rig.left, rig.image_size, left_pose, star, 6.0) ||
        testing::fully_visible(rig.right, rig.image_size, right_pose, star, -4.0) ||
        !testing::fully_visible(rig.right, rig.image_size, right_pose, star, -14.0)) {
      continue;
    }
    testing::RenderOptions options;
    const std::vector<testing::FloorShape> shapes{testing::FloorShape{star, 40.0}};
    const auto left = testing::render_view(rig.left, rig.image_size, left_pose, shapes, options, rng);
    const auto right = testing::render_view(rig.right, rig.image_size, right_pose, shapes, options, rng);
    ASSERT_TRUE(left && right);
    StarCandidate left_star;
    const std::vector<cv::Point2f> edges = star_edges(*left, 0, left_star);
    if (edges.empty()) continue;  // far off the axis the lens may stretch it beyond the shape test
    ++scenes;
    // Without the edge rule the visible part of the outline matches.
    OutlineTransferSearch search;
    const double d = calibration.P1(0, 0) * calibration.baseline() / left_pose.t[2];
    const double offset = calibration.P1(0, 2) - calibration.P2(0, 2);
    search.min_shift_x = -(1.5 * d + offset);
    search.max_shift_x = -(0.6 * d + offset);
    search.edge_margin_px = -1000.0;
    matched_without_edge_rule +=
        transfer_outline(edges, *left, NearRectifier(calibration, 0), *right, NearRectifier(calibration, 1), search).found;
    const StarFix fix = locate(*left, *right, true);
    fixes += fix.found;
  }
  std::printf("[vision] star cut by the right view's edge: %d scenes, outline matched without the edge rule in %d, "
              "fixes %d\n", scenes, matched_without_edge_rule, fixes);
  ASSERT_GE(scenes, 3);
  EXPECT_GE(matched_without_edge_rule, 1) << "the scenes must test the edge rule";
  EXPECT_EQ(fixes, 0);
}

}  // namespace
}  // namespace quad::vision
