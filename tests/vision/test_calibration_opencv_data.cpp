// `vision_station calibrate` on real photographs: OpenCV's own stereo chessboard pairs (Debian opencv-doc,
// examples/data/left01.jpg ... right14.jpg; 13 pairs, 10 missing, 9x6 inner corners). The reference is
// computed here by OpenCV's sample procedure (samples/cpp/stereo_calib.cpp: findChessboardCorners,
// cornerSubPix 11x11, calibrateCamera per camera, stereoCalibrate with the intrinsics fixed). Checks: the
// focal lengths and the baseline within 1 % of the reference; leaving each pair out of the calibration in
// turn, the rectified vertical disparity of its corners <= 0.5 px RMS.
// Exits with 77 (ctest SKIP_RETURN_CODE) when the images are not installed (`apt-get install opencv-doc`).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/chessboard_calibration.h"
#include "quad/vision/stereo_calibration.h"

namespace fs = std::filesystem;

namespace {

using namespace quad::vision;

constexpr int kSkip = 77;
// QUAD_OPENCV_DATA overrides the directory (e.g. to check the skip path).
std::string g_data_dir = "/usr/share/doc/opencv-doc/examples/data";
const int kPairNumbers[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14};
const cv::Size kInnerCorners(9, 6);
constexpr double kSquare = 0.025;  // metres; the sample's board (left_intrinsics.yml square_size)

fs::path g_images;  // the 13 pairs copied (and gunzipped when the package compressed them) for the test

std::string name(const char* side, int number) {
  char text[32];
  std::snprintf(text, sizeof text, "%s%02d.jpg", side, number);
  return text;
}

// Copies the pairs into `out`; false when any is missing. Debian may ship them as NAME.jpg.gz.
bool gather_images(const fs::path& out) {
  fs::create_directories(out);
  for (int number : kPairNumbers) {
    for (const char* side : {"left", "right"}) {
      const fs::path plain = fs::path(g_data_dir) / name(side, number);
      const fs::path zipped = fs::path(g_data_dir) / (name(side, number) + ".gz");
      if (fs::exists(plain)) {
        fs::copy_file(plain, out / name(side, number), fs::copy_options::overwrite_existing);
      } else if (fs::exists(zipped)) {
        const std::string command = "gzip -dc '" + zipped.string() + "' > '" + (out / name(side, number)).string() + "'";
        if (std::system(command.c_str()) != 0) return false;
      } else {
        std::printf("missing %s\n", plain.c_str());
        return false;
      }
    }
  }
  return true;
}

struct Corners {
  std::vector<std::vector<cv::Point2f>> left, right;
  cv::Size size;
};

// OpenCV's sample: findChessboardCorners (adaptive threshold, normalised image), cornerSubPix 11x11.
Corners sample_corners() {
  Corners c;
  for (int number : kPairNumbers) {
    std::vector<cv::Point2f> views[2];
    for (int i = 0; i < 2; ++i) {
      const cv::Mat gray = cv::imread((g_images / name(i == 0 ? "left" : "right", number)).string(), cv::IMREAD_GRAYSCALE);
      EXPECT_FALSE(gray.empty());
      c.size = gray.size();
      const bool found = cv::findChessboardCorners(gray, kInnerCorners, views[i],
                                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
      EXPECT_TRUE(found) << name(i == 0 ? "left" : "right", number);
      cv::cornerSubPix(gray, views[i], cv::Size(11, 11), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 0.01));
    }
    c.left.push_back(views[0]);
    c.right.push_back(views[1]);
  }
  return c;
}

struct Reference {
  cv::Mat K1, D1, K2, D2, R, T;
  double rms_left, rms_right, rms_stereo;
};

Reference sample_calibration(const Corners& c) {
  std::vector<cv::Point3f> board;
  for (int r = 0; r < kInnerCorners.height; ++r)
    for (int col = 0; col < kInnerCorners.width; ++col) board.emplace_back(col * kSquare, r * kSquare, 0.0f);
  const std::vector<std::vector<cv::Point3f>> object(c.left.size(), board);
  Reference ref;
  std::vector<cv::Mat> rvecs, tvecs;
  ref.rms_left = cv::calibrateCamera(object, c.left, c.size, ref.K1, ref.D1, rvecs, tvecs);
  ref.rms_right = cv::calibrateCamera(object, c.right, c.size, ref.K2, ref.D2, rvecs, tvecs);
  cv::Mat E, F;
  ref.rms_stereo = cv::stereoCalibrate(object, c.left, c.right, ref.K1, ref.D1, ref.K2, ref.D2, c.size, ref.R, ref.T,
                                       E, F, cv::CALIB_FIX_INTRINSIC);
  return ref;
}

TEST(OpenCvStereoData, CalibrateMatchesOpenCvSampleProcedure) {
  const fs::path out = fs::temp_directory_path() / ("quad_opencv_data_" + std::to_string(::getpid()) + ".yaml");
  const std::string command = std::string(VISION_STATION_EXE) + " calibrate --images '" + g_images.string() +
                              "' --board 9x6 --square 0.025 --out '" + out.string() + "'";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  const StereoCalibration station = load_calibration(out.string());
  fs::remove(out);

  const Reference ref = sample_calibration(sample_corners());
  const double ref_baseline = cv::norm(ref.T);
  const double errors[] = {station.rig.left.K(0, 0) / ref.K1.at<double>(0, 0) - 1.0,
                           station.rig.left.K(1, 1) / ref.K1.at<double>(1, 1) - 1.0,
                           station.rig.right.K(0, 0) / ref.K2.at<double>(0, 0) - 1.0,
                           station.rig.right.K(1, 1) / ref.K2.at<double>(1, 1) - 1.0,
                           cv::norm(station.rig.T) / ref_baseline - 1.0};
  std::printf("[vision] opencv-doc stereo chessboards (13 pairs): reference (OpenCV sample procedure) RMS left %.3f "
              "right %.3f stereo %.3f px, fx %.2f / %.2f px, baseline %.5f m\n",
              ref.rms_left, ref.rms_right, ref.rms_stereo, ref.K1.at<double>(0, 0), ref.K2.at<double>(0, 0),
              ref_baseline);
  std::printf("[vision] vision_station calibrate vs reference: left fx %+.3f %% fy %+.3f %%, right fx %+.3f %% fy "
              "%+.3f %%, baseline %+.3f %%\n",
              100 * errors[0], 100 * errors[1], 100 * errors[2], 100 * errors[3], 100 * errors[4]);
  for (double e : errors) EXPECT_LT(std::fabs(e), 0.01);
}

// Mean-square row difference of the rectified corners of one pair.
double vertical_disparity_rms(const StereoCalibration& c, std::vector<cv::Point2f> left, std::vector<cv::Point2f> right) {
  // The detector may number a view's corners from either end; left and right look the same way.
  if ((left.back() - left.front()).dot(right.back() - right.front()) < 0.0f) std::reverse(right.begin(), right.end());
  std::vector<cv::Point2f> rl, rr;
  cv::undistortPoints(left, rl, cv::Mat(c.rig.left.K), cv::Mat(c.rig.left.D), cv::Mat(c.R1), cv::Mat(c.P1));
  cv::undistortPoints(right, rr, cv::Mat(c.rig.right.K), cv::Mat(c.rig.right.D), cv::Mat(c.R2), cv::Mat(c.P2));
  double sum = 0.0;
  for (size_t i = 0; i < rl.size(); ++i) sum += (rl[i].y - rr[i].y) * (rl[i].y - rr[i].y);
  return std::sqrt(sum / static_cast<double>(rl.size()));
}

TEST(OpenCvStereoData, LeaveOnePairOutRectifiedRowsAgree) {
  const ChessboardSpec board{kInnerCorners, kSquare};
  std::vector<std::vector<cv::Point2f>> left, right;
  cv::Size size;
  for (int number : kPairNumbers) {
    const cv::Mat l = cv::imread((g_images / name("left", number)).string(), cv::IMREAD_GRAYSCALE);
    const cv::Mat r = cv::imread((g_images / name("right", number)).string(), cv::IMREAD_GRAYSCALE);
    size = l.size();
    const auto cl = find_chessboard(l, board);
    const auto cr = find_chessboard(r, board);
    ASSERT_TRUE(cl && cr) << "pair " << number;
    left.push_back(*cl);
    right.push_back(*cr);
  }
  const CalibrationRequirements requirements;  // 12 pairs each time, above the minimum of 10
  double worst = 0.0;
  std::string line;
  for (size_t out = 0; out < left.size(); ++out) {
    std::vector<std::vector<cv::Point2f>> l = left, r = right;
    l.erase(l.begin() + static_cast<long>(out));
    r.erase(r.begin() + static_cast<long>(out));
    const StereoCalibrationResult result = calibrate_stereo(l, r, size, board, requirements);
    const double rms = vertical_disparity_rms(result.calibration, left[out], right[out]);
    worst = std::max(worst, rms);
    char text[48];
    std::snprintf(text, sizeof text, " %02d:%.3f", kPairNumbers[out], rms);
    line += text;
    EXPECT_LE(rms, 0.5) << "pair " << kPairNumbers[out] << " left out";
  }
  std::printf("[vision] leave-one-pair-out rectified vertical disparity RMS (px) per pair:%s; worst %.3f px\n",
              line.c_str(), worst);
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  if (const char* dir = std::getenv("QUAD_OPENCV_DATA")) g_data_dir = dir;
  g_images = fs::temp_directory_path() / ("quad_opencv_data_" + std::to_string(::getpid()));
  if (!gather_images(g_images)) {
    std::printf("SKIPPED: OpenCV's stereo chessboard images are not in %s (apt-get install opencv-doc)\n", g_data_dir.c_str());
    fs::remove_all(g_images);
    return kSkip;
  }
  const int status = RUN_ALL_TESTS();
  fs::remove_all(g_images);
  return status;
}
