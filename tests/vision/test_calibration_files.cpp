// The calibration loader's accepted forms: the station's own file, a file with only K1 D1 K2 D2 R T (the
// rectification is then computed), and OpenCV's stereo_calib sample pair (M1 D1 M2 D2 in an intrinsics
// file, R T R1 R2 P1 P2 Q in an extrinsics file); errors name the file and the field.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <string>

#include <opencv2/calib3d.hpp>

#include "quad/vision/stereo_calibration.h"

namespace quad::vision {
namespace {

namespace fs = std::filesystem;

class CalibrationFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("quad_calib_files_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // A rig unlike the thesis one, built here: 640x480, 0.09 m baseline, small relative rotation.
    rig_.image_size = cv::Size(640, 480);
    rig_.left = CameraIntrinsics{cv::Matx33d(530, 0, 322, 0, 528, 241, 0, 0, 1), cv::Vec<double, 5>(-0.21, 0.05, 0.001, 0, 0)};
    rig_.right = CameraIntrinsics{cv::Matx33d(536, 0, 318, 0, 535, 236, 0, 0, 1), cv::Vec<double, 5>(-0.19, 0.03, 0, 0.0005, 0)};
    cv::Mat R;
    cv::Rodrigues(cv::Vec3d(0.004, -0.01, 0.002), R);
    rig_.R = cv::Matx33d(R);
    rig_.T = cv::Vec3d(-0.09, 0.001, -0.0005);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string path(const char* name) const { return (dir_ / name).string(); }

  // OpenCV's sample writes D as a row vector (1x5 here, 1x8 with the rational model).
  void write_intrinsics(const std::string& file, const char* k1, const char* k2, const cv::Mat& d1) const {
    cv::FileStorage fs(file, cv::FileStorage::WRITE);
    fs << k1 << cv::Mat(rig_.left.K) << "D1" << d1 << k2 << cv::Mat(rig_.right.K) << "D2" << cv::Mat(rig_.right.D).t();
  }

  fs::path dir_;
  StereoRig rig_;
};

TEST_F(CalibrationFiles, IntrinsicsAndExtrinsicsOnlyGetTheirRectificationComputed) {
  write_intrinsics(path("k.yaml"), "K1", "K2", cv::Mat(rig_.left.D).t());
  {
    cv::FileStorage fs(path("k.yaml"), cv::FileStorage::APPEND);
    fs << "image_width" << 640 << "image_height" << 480 << "R" << cv::Mat(rig_.R) << "T" << cv::Mat(rig_.T);
  }
  const StereoCalibration c = load_calibration(path("k.yaml"));
  EXPECT_TRUE(c.rectification_computed);
  const StereoCalibration expected = rectify(rig_);  // the same call the station's calibrate makes
  EXPECT_LT(cv::norm(cv::Mat(c.P1), cv::Mat(expected.P1)), 1e-9);
  EXPECT_LT(cv::norm(cv::Mat(c.P2), cv::Mat(expected.P2)), 1e-9);
  EXPECT_LT(cv::norm(cv::Mat(c.R1), cv::Mat(expected.R1)), 1e-12);
  EXPECT_NEAR(c.baseline(), cv::norm(rig_.T), 1e-9);
}

TEST_F(CalibrationFiles, OpenCvSampleIntrinsicsPlusExtrinsics) {
  write_intrinsics(path("intrinsics.yml"), "M1", "M2", cv::Mat(rig_.left.D).t());
  // The sample's stereoRectify call (CALIB_ZERO_DISPARITY, alpha 1) differs from the station's: the
  // loaded P1/P2 must be the file's, not recomputed ones.
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(cv::Mat(rig_.left.K), cv::Mat(rig_.left.D), cv::Mat(rig_.right.K), cv::Mat(rig_.right.D),
                    rig_.image_size, cv::Mat(rig_.R), cv::Mat(rig_.T), R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 1,
                    rig_.image_size);
  {
    cv::FileStorage fs(path("extrinsics.yml"), cv::FileStorage::WRITE);
    fs << "R" << cv::Mat(rig_.R) << "T" << cv::Mat(rig_.T) << "R1" << R1 << "R2" << R2 << "P1" << P1 << "P2" << P2
       << "Q" << Q;
  }
  try {
    load_calibration(path("intrinsics.yml") + "," + path("extrinsics.yml"));
    FAIL() << "a pair without the image size was accepted";
  } catch (const CalibrationFileError& e) {
    EXPECT_NE(std::string(e.what()).find("'image_width'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("extrinsics.yml"), std::string::npos) << e.what();
  }
  {
    cv::FileStorage fs(path("extrinsics.yml"), cv::FileStorage::APPEND);
    fs << "image_width" << 640 << "image_height" << 480;
  }
  const StereoCalibration c = load_calibration(path("intrinsics.yml") + "," + path("extrinsics.yml"));
  EXPECT_FALSE(c.rectification_computed);
  EXPECT_LT(cv::norm(cv::Mat(c.P1), P1), 1e-9);
  EXPECT_LT(cv::norm(cv::Mat(c.rig.left.K), cv::Mat(rig_.left.K)), 1e-12);
  EXPECT_LT(cv::norm(cv::Mat(c.rig.right.D), cv::Mat(rig_.right.D)), 1e-12);
  EXPECT_EQ(c.rig.image_size, rig_.image_size);
}

TEST_F(CalibrationFiles, ErrorsNameTheFileAndTheField) {
  write_intrinsics(path("no_t.yaml"), "K1", "K2", cv::Mat(rig_.left.D).t());
  {
    cv::FileStorage fs(path("no_t.yaml"), cv::FileStorage::APPEND);
    fs << "image_width" << 640 << "image_height" << 480 << "R" << cv::Mat(rig_.R);
  }
  try {
    load_calibration(path("no_t.yaml"));
    FAIL();
  } catch (const CalibrationFileError& e) {
    EXPECT_EQ(std::string(e.what()), path("no_t.yaml") + ": missing key 'T'");
  }
  // A rational-model D1 (8 coefficients, k4..k6 non-zero) cannot be represented by the station's lens model.
  const cv::Mat d8 = (cv::Mat_<double>(1, 8) << -0.2, 0.05, 0, 0, 0, 0.01, 0, 0);
  write_intrinsics(path("rational.yaml"), "K1", "K2", d8);
  {
    cv::FileStorage fs(path("rational.yaml"), cv::FileStorage::APPEND);
    fs << "image_width" << 640 << "image_height" << 480 << "R" << cv::Mat(rig_.R) << "T" << cv::Mat(rig_.T);
  }
  try {
    load_calibration(path("rational.yaml"));
    FAIL();
  } catch (const CalibrationFileError& e) {
    EXPECT_NE(std::string(e.what()).find(path("rational.yaml") + ": key 'D1'"), std::string::npos) << e.what();
  }
  // The same 8-vector with zero k4..k6 is the 5-term model.
  const cv::Mat d8_plain = (cv::Mat_<double>(1, 8) << -0.2, 0.05, 0, 0, 0.001, 0, 0, 0);
  write_intrinsics(path("plain8.yaml"), "K1", "K2", d8_plain);
  {
    cv::FileStorage fs(path("plain8.yaml"), cv::FileStorage::APPEND);
    fs << "image_width" << 640 << "image_height" << 480 << "R" << cv::Mat(rig_.R) << "T" << cv::Mat(rig_.T);
  }
  EXPECT_DOUBLE_EQ(load_calibration(path("plain8.yaml")).rig.left.D[4], 0.001);
  // Only part of the rectification: name the first missing key.
  {
    cv::FileStorage fs(path("plain8.yaml"), cv::FileStorage::APPEND);
    fs << "R1" << cv::Mat(cv::Matx33d::eye());
  }
  try {
    load_calibration(path("plain8.yaml"));
    FAIL();
  } catch (const CalibrationFileError& e) {
    EXPECT_NE(std::string(e.what()).find("missing key 'R2'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace quad::vision
