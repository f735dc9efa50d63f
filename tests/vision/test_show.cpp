// vision_station run --show end to end: without a display it refuses before doing any
// work; under a virtual X server (xvfb-run, skipped without it) it opens the window, and the frame the
// window displayed (--show-screenshot) holds both camera views, the detected contour in red around the
// star's known location in each view, and the green fix/latency line.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/ideal_star.h"
#include "quad/vision/stereo_calibration.h"
#include "star_scenes.h"
#include "x_display.h"

namespace quad::vision {
namespace {

namespace fs = std::filesystem;

using quad_test::exit_code;
using quad_test::have_xvfb;
using quad_test::read_text;

// The screen is wide enough for the 2 × 728 px window.
// OpenCV's Qt display backend leaves libdbus and fontconfig allocations alive at exit, which
// LeakSanitizer reports under host-debug: suppressed by library name, the station's own code still checked.
const std::string kXvfb = quad_test::xvfb_run("1600x900x24", "LSAN_OPTIONS=suppressions=" QUAD_LSAN_DISPLAY_SUPP);

// Rendered pairs (files: source, pairs.csv order) and the thesis calibration; for each pair, where the
// star's centre and a tip project in both views.
class ShowTest : public ::testing::Test {
 protected:
  fs::path dir = fs::temp_directory_path() / ("vision_show_" + std::to_string(::getpid()));
  struct Expected {
    cv::Point2d centre[2];
    double radius_px[2];  // centre to the farthest projected tip
  };
  std::vector<Expected> expected;
  cv::Size size;

  void SetUp() override {
    fs::remove_all(dir);
    fs::create_directories(dir / "pairs");
    const StereoRig rig = thesis_stereo_rig();
    size = rig.image_size;
    save_calibration(rectify(rig), (dir / "calib.yaml").string());
    cv::RNG rng(62);
    std::ofstream csv(dir / "pairs" / "pairs.csv");
    csv << "left,right\n";
    const testing::StarSceneRanges ranges;
    for (int i = 0; i < 3; ++i) {
      const auto scene = testing::random_star_scene(rig, rng, ranges);
      ASSERT_TRUE(scene);
      const std::string l = "left" + std::to_string(i) + ".png", r = "right" + std::to_string(i) + ".png";
      cv::imwrite((dir / "pairs" / l).string(), scene->left);
      cv::imwrite((dir / "pairs" / r).string(), scene->right);
      csv << l << "," << r << "\n";
      Expected e;
      const testing::Pose poses[2] = {scene->left_pose, testing::right_pose(rig, scene->left_pose)};
      const CameraIntrinsics* cameras[2] = {&rig.left, &rig.right};
      for (int v = 0; v < 2; ++v) {
        const auto c = testing::project(*cameras[v], poses[v], cv::Point2d(0, 0));
        ASSERT_TRUE(c);
        e.centre[v] = *c;
        e.radius_px[v] = 0.0;
        for (const cv::Point2d& vertex : star_vertices(ranges.star)) {
          const auto p = testing::project(*cameras[v], poses[v], vertex);
          ASSERT_TRUE(p);
          e.radius_px[v] = std::max(e.radius_px[v], cv::norm(*p - *c));
        }
      }
      expected.push_back(e);
    }
  }
  void TearDown() override { fs::remove_all(dir); }

  std::string run_args(const fs::path& shot) const {
    return "run --calib '" + (dir / "calib.yaml").string() + "' --source 'files:" + (dir / "pairs").string() +
           "' --status-s 0 --show --show-screenshot '" + shot.string() + "'";
  }
};

TEST_F(ShowTest, WithoutDisplayFailsBeforeDoingAnyWork) {
  const fs::path shot = dir / "shot.png", err = dir / "stderr.txt";
  // A serial port that cannot be opened: the display error must come first, before any of the setup.
  const std::string cmd = "env -u DISPLAY -u WAYLAND_DISPLAY '" VISION_STATION_EXE "' " + run_args(shot) +
                          " --out '" + (dir / "no_such_port").string() + "' >/dev/null 2>'" + err.string() + "'";
  EXPECT_EQ(exit_code(cmd), 1);
  const std::string text = read_text(err);
  EXPECT_NE(text.find("vision_station run: --show needs a display (DISPLAY or WAYLAND_DISPLAY is not set)"),
            std::string::npos)
      << text;
  EXPECT_EQ(text.find("no_such_port"), std::string::npos) << "the port was opened before the display check";
  EXPECT_EQ(text.find("fps"), std::string::npos) << "frames were processed: " << text;
  EXPECT_EQ(text.find("total:"), std::string::npos) << text;
  EXPECT_FALSE(fs::exists(shot));
}

TEST_F(ShowTest, ScreenshotWithoutShowIsAUsageError) {
  const fs::path err = dir / "stderr.txt";
  const std::string cmd = "'" VISION_STATION_EXE "' run --calib '" + (dir / "calib.yaml").string() +
                          "' --source 'files:" + (dir / "pairs").string() + "' --show-screenshot '" +
                          (dir / "shot.png").string() + "' >/dev/null 2>'" + err.string() + "'";
  EXPECT_EQ(exit_code(cmd), 2);
  EXPECT_NE(read_text(err).find("--show-screenshot needs --show"), std::string::npos) << read_text(err);
}

TEST_F(ShowTest, WindowShowsBothViewsContourAndFixUnderXvfb) {
  if (!have_xvfb()) GTEST_SKIP() << "xvfb-run is not installed (tools/packages-debian.txt: xvfb)";
  const fs::path shot = dir / "shot.png", err = dir / "stderr.txt";
  const std::string cmd = kXvfb + "'" VISION_STATION_EXE "' " + run_args(shot) + " >/dev/null 2>'" + err.string() + "'";
  ASSERT_EQ(exit_code(cmd), 0) << read_text(err);
  EXPECT_NE(read_text(err).find("total: 3 frames, 3 fixes"), std::string::npos) << read_text(err);

  // The screenshot is the last pair shown.
  const cv::Mat bgr = cv::imread(shot.string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(bgr.empty()) << "no screenshot at " << shot;
  ASSERT_EQ(bgr.cols, 2 * size.width) << "not both views side by side";
  ASSERT_EQ(bgr.rows, size.height);
  const Expected& e = expected.back();

  cv::Mat red, green;  // the contour's and the text's colours, exactly as drawn (PNG is lossless)
  cv::inRange(bgr, cv::Scalar(0, 0, 200), cv::Scalar(60, 60, 255), red);
  cv::inRange(bgr, cv::Scalar(0, 200, 0), cv::Scalar(60, 255, 60), green);

  for (int v = 0; v < 2; ++v) {
    SCOPED_TRACE(v == 0 ? "left view" : "right view");
    const cv::Rect half(v * size.width, 0, size.width, size.height);
    const cv::Mat view = bgr(half), view_red = red(half);
    // A camera view: the light floor fills most of it, and the dark star is where it should be.
    cv::Mat grey;
    cv::cvtColor(view, grey, cv::COLOR_BGR2GRAY);
    EXPECT_GT(cv::mean(grey)[0], 100.0) << "no camera image in this half";
    const cv::Point c(cvRound(e.centre[v].x), cvRound(e.centre[v].y));
    EXPECT_LT(grey.at<uint8_t>(c), 100) << "the star centre at " << c << " is not dark";

    // The contour: red pixels, all of them around the star (within its tips, plus the 2 px line), none
    // elsewhere, their centre near the star's, and far enough out to be its outline.
    std::vector<cv::Point> pixels;
    cv::findNonZero(view_red, pixels);
    ASSERT_GT(pixels.size(), 4 * e.radius_px[v]) << "no contour drawn";
    cv::Point2d mean(0, 0);
    double farthest = 0.0, mean_distance = 0.0;
    for (const cv::Point& p : pixels) {
      mean += cv::Point2d(p);
      const double d = cv::norm(cv::Point2d(p) - e.centre[v]);
      farthest = std::max(farthest, d);
      mean_distance += d;
    }
    mean *= 1.0 / pixels.size();
    mean_distance /= pixels.size();
    EXPECT_LT(farthest, e.radius_px[v] + 4.0) << "red pixels away from the star (radius " << e.radius_px[v] << " px)";
    EXPECT_LT(cv::norm(mean - e.centre[v]), 0.25 * e.radius_px[v]) << "contour centre " << mean << " vs star "
                                                                       << e.centre[v];
    EXPECT_GT(mean_distance, 0.3 * e.radius_px[v]) << "red blob rather than an outline";
  }

  // The fix and latency line: green text in the top band of the left view, and no green anywhere else.
  const cv::Rect band(0, 0, size.width, 36);
  const int text_pixels = cv::countNonZero(green(band));
  EXPECT_GT(text_pixels, 500) << "no fix/latency text";
  EXPECT_EQ(cv::countNonZero(green), text_pixels) << "green outside the text band";
  // The line is long ("star (x, y, z) m  t ms", ~30 characters), not "no fix  t ms".
  std::vector<cv::Point> text;
  cv::findNonZero(green(band), text);
  EXPECT_GT(cv::boundingRect(text).width, 300);
}

}  // namespace
}  // namespace quad::vision
