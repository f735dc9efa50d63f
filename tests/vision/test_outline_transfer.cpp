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

  // The outline's lowest point (largest row).
  static cv::Point2d lowest_point(const std::vector<cv::Point>& contour) {
    cv::Point2d lowest(0.0, -1.0);
    for (const cv::Point& p : contour) {
      if (p.y > lowest.y) lowest = cv::Point2d(p);
    }
    return lowest;
  }

  // The star's core grey: the mean over a 3 px disc at its outline's centre.
  static cv::Scalar core_grey(const cv::Mat& gray, const std::vector<cv::Point>& contour) {
    cv::Point2d centre(0.0, 0.0);
    for (const cv::Point& p : contour) centre += cv::Point2d(p);
    centre *= 1.0 / static_cast<double>(contour.size());
    cv::Mat mask = cv::Mat::zeros(gray.size(), CV_8UC1);
    cv::circle(mask, centre, 3, cv::Scalar(255), cv::FILLED);
    return cv::mean(gray, mask);
  }

  // A strip of grey `dark` from the star's lowest point straight down past the image's bottom edge: the
  // star's outline there runs into the edge.
  static void strip_to_bottom_edge(cv::Mat& gray, const StarCandidate& star, const cv::Scalar& dark) {
    const cv::Point2d lowest = lowest_point(star.contour);
    const int width = std::max(6, star.box.width / 10);
    cv::line(gray, lowest, cv::Point2d(lowest.x, gray.rows + 10.0), dark, width, cv::LINE_AA);
  }

  // The fixes with outline transfer over the scenes: how many were found, each by transfer, and the
  // worst error as a fraction of the range.
  struct TransferTally {
    int scenes = 0, found = 0;
    double worst = 0.0;
    void add(const StarFix& fix, const cv::Vec3d& truth) {
      ++scenes;
      found += fix.found;
      if (!fix.found) return;
      EXPECT_TRUE(fix.transferred);
      worst = std::max(worst, cv::norm(fix.p_left - truth) / cv::norm(truth));
    }
  };

  StereoRig rig = thesis_stereo_rig();
  StereoCalibration calibration = rectify(rig);
};

TEST_F(OutlineTransferTest, AStarMergedWithAStripToTheEdgeIsFoundByTheOtherViewsOutline) {
  cv::RNG rng(7);
  const testing::StarSceneRanges ranges = testing::heights_between(1.2, 1.8);
  int strict_found = 0;
  TransferTally tally;
  for (int k = 0; k < 6; ++k) {
    auto scene = testing::random_star_scene(rig, rng, ranges);
    ASSERT_TRUE(scene);
    StarCandidate right_star;
    ASSERT_FALSE(star_edges(scene->right, 1, right_star).empty());
    // A strip as dark as the star's core through its lowest point to the bottom edge.
    cv::Mat right = scene->right.clone();
    strip_to_bottom_edge(right, right_star, core_grey(scene->right, right_star.contour));
    strict_found += locate(scene->left, right, false).found;
    tally.add(locate(scene->left, right, true), scene->truth_left);
  }
  std::printf("[vision] star merged with a strip to the edge in the right view: %d scenes, found %d without "
              "outline transfer, %d with it (worst error %.2f %% of the range)\n",
              tally.scenes, strict_found, tally.found, 100.0 * tally.worst);
  EXPECT_EQ(strict_found, 0) << "the strip must cost the star its outline in the right view";
  EXPECT_EQ(tally.found, tally.scenes);
  EXPECT_LT(tally.worst, 0.02);
}

TEST_F(OutlineTransferTest, ANearMissWhoseOutlineDoesNotAlignGivesWayToTheOtherViewsOutline) {
  // A dark stub hanging from the star's lowest tip in the right view: the outline there fails the shape
  // test but stays a near miss, which pairs with the left star and is then refused because the two
  // outlines do not lay onto each other. The left star's outline, sought in the right view, finds the
  // star's own edges there.
  cv::RNG rng(5);
  const testing::StarSceneRanges ranges = testing::heights_between(1.0, 1.6);
  TransferTally tally;
  for (int k = 0; k < 60 && tally.scenes < 4; ++k) {
    auto scene = testing::random_star_scene(rig, rng, ranges);
    ASSERT_TRUE(scene);
    StarCandidate right_star;
    if (star_edges(scene->right, 1, right_star).empty()) continue;
    const cv::Point2d lowest = lowest_point(right_star.contour);
    cv::Mat right = scene->right.clone();
    const double length = 0.35 * right_star.box.height;
    const int width = std::max(4, right_star.box.width / 12);
    cv::line(right, lowest, lowest + cv::Point2d(0.3 * length, length), cv::Scalar(30), width, cv::LINE_AA);
    const StarFix without = locate(scene->left, right, false);
    if (without.refused == nullptr || std::string(without.refused) != "guided outlines misaligned") continue;
    tally.add(locate(scene->left, right, true), scene->truth_left);
  }
  std::printf("[vision] near miss refused as misaligned in the right view: %d scenes, found %d by outline "
              "transfer (worst error %.2f %% of the range)\n", tally.scenes, tally.found, 100.0 * tally.worst);
  ASSERT_GE(tally.scenes, 3) << "the stub must leave a near miss that pairs and is refused";
  EXPECT_EQ(tally.found, tally.scenes);
  EXPECT_LT(tally.worst, 0.02);
}

TEST_F(OutlineTransferTest, AStarLostInTheLeftViewIsFoundWhenTheLeftCandidatePlacedTheRightSearchElsewhere) {
  // The left view: the star merged with a strip to the image's edge, and a star-shaped blot far from it
  // that passes the shape test, so the right view is searched only where the blot could appear. The
  // blot has no counterpart in the right view; the star, whole there, is found once the right view is
  // searched whole and its outline sought in the left view.
  cv::RNG rng(9);
  const testing::StarSceneRanges ranges = testing::heights_between(1.2, 1.8);
  TransferTally tally;
  for (int k = 0; k < 40 && tally.scenes < 4; ++k) {
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
    const cv::Scalar dark = core_grey(scene->left, left_star.contour);
    cv::fillPoly(left, std::vector<std::vector<cv::Point>>{blot}, dark, cv::LINE_AA);
    strip_to_bottom_edge(left, left_star, dark);
    if (locate(left, scene->right, false).found) continue;  // the blot's window held the star after all
    tally.add(locate(left, scene->right, true), scene->truth_left);
  }
  std::printf("[vision] star lost in the left view, a blot placing the right search elsewhere: %d scenes, "
              "found %d by outline transfer from the whole right view (worst error %.2f %% of the range)\n",
              tally.scenes, tally.found, 100.0 * tally.worst);
  ASSERT_GE(tally.scenes, 3) << "the strip and the blot must cost the star its fix without outline transfer";
  EXPECT_EQ(tally.found, tally.scenes);
  EXPECT_LT(tally.worst, 0.02);
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
