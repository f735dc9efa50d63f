// Stereo calibration on chessboards rendered through the thesis rig with known intrinsics: the focal
// lengths within 0.5 %, the baseline within 1 %; too few or degenerate views are refused.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <opencv2/imgcodecs.hpp>

#include "quad/vision/chessboard_calibration.h"
#include "scene_renderer.h"

namespace quad::vision {
namespace {

using testing::FloorShape;
using testing::Pose;

constexpr double kSquare = 0.035;
const ChessboardSpec kBoard{cv::Size(9, 6), kSquare};

// The board's black squares in board coordinates, origin at the first inner corner (the corner order
// find_chessboard reports, so that object points line up).
std::vector<FloorShape> board_shapes() {
  std::vector<FloorShape> squares;
  for (int r = -1; r < kBoard.inner_corners.height; ++r) {
    for (int c = -1; c < kBoard.inner_corners.width; ++c) {
      if (((r + c) & 1) != 0) continue;
      const double x = c * kSquare, y = r * kSquare;
      squares.push_back(FloorShape{{{x, y}, {x + kSquare, y}, {x + kSquare, y + kSquare}, {x, y + kSquare}}, 25.0});
    }
  }
  return squares;
}

struct Views {
  std::vector<std::vector<cv::Point2f>> left, right;
  std::vector<cv::Mat> left_images, right_images;
};

// Boards at 0.45–0.8 m, tilted up to `max_tilt`, spread over the image; only views in which both
// cameras see the whole board (inside the lens model's valid field) are kept.
Views capture(const StereoRig& rig, int count, double max_tilt, cv::RNG& rng) {
  Views views;
  const cv::Point2d board_centre(0.5 * (kBoard.inner_corners.width - 1) * kSquare,
                                 0.5 * (kBoard.inner_corners.height - 1) * kSquare);
  const std::vector<cv::Point2d> outline{{-2 * kSquare, -2 * kSquare},
                                         {(kBoard.inner_corners.width + 1) * kSquare, -2 * kSquare},
                                         {(kBoard.inner_corners.width + 1) * kSquare, (kBoard.inner_corners.height + 1) * kSquare},
                                         {-2 * kSquare, (kBoard.inner_corners.height + 1) * kSquare}};
  testing::RenderOptions options;
  options.floor_grey = 225.0;
  for (int attempt = 0; static_cast<int>(views.left.size()) < count && attempt < 100 * count; ++attempt) {
    const cv::Point2d ray(rng.uniform(-0.55, 0.55), rng.uniform(-0.4, 0.5));
    const Pose left = testing::camera_pose(rng.uniform(0.45, 0.8), rng.uniform(0.0, max_tilt),
                                           rng.uniform(0.0, 2.0 * CV_PI), rng.uniform(-0.3, 0.3), ray, board_centre);
    const Pose right = testing::right_pose(rig, left);
    if (!testing::fully_visible(rig.left, rig.image_size, left, outline, 3.0) ||
        !testing::fully_visible(rig.right, rig.image_size, right, outline, 3.0)) {
      continue;
    }
    const auto l = testing::render_view(rig.left, rig.image_size, left, board_shapes(), options, rng);
    const auto r = testing::render_view(rig.right, rig.image_size, right, board_shapes(), options, rng);
    if (!l || !r) continue;
    const auto cl = find_chessboard(*l, kBoard);
    const auto cr = find_chessboard(*r, kBoard);
    if (!cl || !cr) continue;
    views.left.push_back(*cl);
    views.right.push_back(*cr);
    views.left_images.push_back(*l);
    views.right_images.push_back(*r);
  }
  return views;
}

// 18 views rendered once for the tests that need a good set.
const Views& good_views() {
  static const Views views = [] {
    cv::RNG rng(7);
    return capture(thesis_stereo_rig(), 18, 40.0 * CV_PI / 180.0, rng);
  }();
  return views;
}

TEST(StereoCalibrationTest, RecoversTheThesisRigFromRenderedChessboards) {
  const StereoRig truth = thesis_stereo_rig();
  Views views = good_views();
  ASSERT_EQ(views.left.size(), 18u);
  // The corner order of a view may start from either end of the board: every third right view reversed
  // must not matter.
  for (size_t i = 0; i < views.right.size(); i += 3) std::reverse(views.right[i].begin(), views.right[i].end());
  const StereoCalibrationResult result = calibrate_stereo(views.left, views.right, truth.image_size, kBoard);
  const StereoRig& rig = result.calibration.rig;
  const double fx1 = rig.left.K(0, 0) / truth.left.K(0, 0) - 1.0, fy1 = rig.left.K(1, 1) / truth.left.K(1, 1) - 1.0;
  const double fx2 = rig.right.K(0, 0) / truth.right.K(0, 0) - 1.0, fy2 = rig.right.K(1, 1) / truth.right.K(1, 1) - 1.0;
  const double baseline = cv::norm(rig.T) / cv::norm(truth.T) - 1.0;
  std::printf("[vision] calibration from %d rendered pairs: RMS left %.3f right %.3f stereo %.3f px; focal error "
              "left fx %+.3f %% fy %+.3f %%, right fx %+.3f %% fy %+.3f %%; baseline %.4f m (%+.3f %%)\n",
              result.pairs, result.rms_left_px, result.rms_right_px, result.rms_stereo_px, 100 * fx1, 100 * fy1,
              100 * fx2, 100 * fy2, cv::norm(rig.T), 100 * baseline);
  EXPECT_LT(std::fabs(fx1), 0.005);
  EXPECT_LT(std::fabs(fy1), 0.005);
  EXPECT_LT(std::fabs(fx2), 0.005);
  EXPECT_LT(std::fabs(fy2), 0.005);
  EXPECT_LT(std::fabs(baseline), 0.01);
  EXPECT_LT(result.rms_stereo_px, 0.5);
  // The rectified rig is horizontal with the right camera on the right.
  EXPECT_NEAR(result.calibration.baseline(), cv::norm(truth.T), 0.01 * cv::norm(truth.T));
}

TEST(StereoCalibrationTest, RefusesUnsynchronisedPairs) {
  const StereoRig truth = thesis_stereo_rig();
  Views views = good_views();
  ASSERT_EQ(views.left.size(), 18u);
  // Each right view paired with the next left view: the board moved between the two images.
  std::rotate(views.right.begin(), views.right.begin() + 1, views.right.end());
  try {
    calibrate_stereo(views.left, views.right, truth.image_size, kBoard);
    FAIL() << "unsynchronised pairs accepted";
  } catch (const CalibrationSetError& e) {
    EXPECT_NE(std::string(e.what()).find("not taken at the same time"), std::string::npos) << e.what();
  }
}

TEST(StereoCalibrationTest, RefusesTooFewViews) {
  const StereoRig truth = thesis_stereo_rig();
  cv::RNG rng(8);
  const Views views = capture(truth, 5, 40.0 * CV_PI / 180.0, rng);
  try {
    calibrate_stereo(views.left, views.right, truth.image_size, kBoard);
    FAIL() << "5 views accepted";
  } catch (const CalibrationSetError& e) {
    EXPECT_NE(std::string(e.what()).find("capture at least 10"), std::string::npos) << e.what();
  }
}

TEST(StereoCalibrationTest, RefusesFrontoParallelViews) {
  const StereoRig truth = thesis_stereo_rig();
  cv::RNG rng(9);
  const Views views = capture(truth, 14, 3.0 * CV_PI / 180.0, rng);
  try {
    calibrate_stereo(views.left, views.right, truth.image_size, kBoard);
    FAIL() << "fronto-parallel views accepted";
  } catch (const CalibrationSetError& e) {
    EXPECT_NE(std::string(e.what()).find("tilted"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace quad::vision

namespace quad::vision {
namespace {

// `vision_station calibrate --images DIR` end to end on rendered chessboard files.
TEST(CalibrateCommandTest, WritesACalibrationFileFromImagePairs) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("vision_calibrate_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const StereoRig truth = thesis_stereo_rig();
  cv::RNG rng(10);
  const Views views = capture(truth, 14, 40.0 * CV_PI / 180.0, rng);
  int written = 0;
  for (size_t i = 0; i < views.left_images.size(); ++i, ++written) {
    const std::string suffix = std::to_string(100 + i) + ".png";
    cv::imwrite((dir / ("left" + suffix)).string(), views.left_images[i]);
    cv::imwrite((dir / ("right" + suffix)).string(), views.right_images[i]);
  }
  ASSERT_EQ(written, 14);
  const std::string out = (dir / "calib.yaml").string();
  const std::string log = (dir / "log.txt").string();
  const std::string command = std::string(VISION_STATION_EXE) + " calibrate --images " + dir.string() +
                              " --board 9x6 --square " + std::to_string(kSquare) + " --out " + out + " >" + log + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const StereoCalibration c = load_calibration(out);
  EXPECT_NEAR(c.baseline(), cv::norm(truth.T), 0.01 * cv::norm(truth.T));
  EXPECT_NEAR(c.rig.left.K(1, 1), truth.left.K(1, 1), 0.005 * truth.left.K(1, 1));
  std::ifstream in(log);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("calibrated from 14 views"), std::string::npos) << text;
  EXPECT_NE(text.find("baseline 0.11"), std::string::npos) << text;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace quad::vision
