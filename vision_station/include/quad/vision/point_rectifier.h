// Undistortion and rectification of image points (never whole frames): raw pixels of one camera to the
// pixels of the rectified stereo view.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/stereo_calibration.h"

namespace quad::vision {

class PointRectifier {
 public:
  // The identity: points pass unchanged (detection on images that are already rectified).
  PointRectifier() = default;
  // Camera 0 (left) or 1 (right) of a calibration.
  PointRectifier(const StereoCalibration& calibration, int camera, int iterations);

  void apply(const std::vector<cv::Point>& raw, std::vector<cv::Point2f>& rectified) const;

 private:
  bool identity_ = true;
  cv::Mat K_, D_, R_, P_;
  int iterations_ = 0;
  mutable std::vector<cv::Point2f> scratch_;
};

}  // namespace quad::vision
