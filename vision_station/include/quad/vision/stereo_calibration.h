// The stereo calibration file: intrinsics, extrinsics and rectification of the two cameras, stored as
// an OpenCV FileStorage YAML (keys image_width, image_height, K1, D1, K2, D2, R, T, R1, R2, P1, P2, Q).
#pragma once

#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include "quad/vision/thesis_rig.h"

namespace quad::vision {

struct CalibrationFileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A rig plus its rectification (cv::stereoRectify): R1/R2 rotate each camera into the common
// rectified frame, P1/P2 project rectified points, Q reprojects (u, v, disparity) to 3D.
struct StereoCalibration {
  StereoRig rig;
  cv::Matx33d R1, R2;
  cv::Matx34d P1, P2;
  cv::Matx44d Q;
  bool rectification_computed = false;  // the file had no R1 R2 P1 P2 Q: load_calibration computed them

  double rectified_focal() const { return P1(0, 0); }
  // Rectified baseline in metres (P2(0,3) = −f·b for a horizontal rig).
  double baseline() const { return -P2(0, 3) / P2(0, 0); }
};

// Computes the rectification of a rig (cv::stereoRectify with CALIB_ZERO_DISPARITY, default alpha).
StereoCalibration rectify(const StereoRig& rig);

// Writes / reads the YAML file. load_calibration takes one file, or OpenCV's stereo_calib sample pair
// "INTRINSICS.yml,EXTRINSICS.yml" (M1 D1 M2 D2 + R T ...; K1/K2 and M1/M2 are accepted as synonyms);
// without R1 R2 P1 P2 Q the rectification is computed (rectification_computed). Throws
// CalibrationFileError naming the file and the missing or malformed key.
void save_calibration(const StereoCalibration& calibration, const std::string& path);
StereoCalibration load_calibration(const std::string& path);

}  // namespace quad::vision
