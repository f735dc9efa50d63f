// Raw image point → rectified point by bilinear interpolation in a table of exact undistort+rectify
// results on a grid every `step` pixels (PointRectifier on the grid nodes, once per image size). The lens
// map is smooth, so a 2-px grid is exact to about 0.01 px inside the lens model's valid field, and a
// contour point costs nanoseconds instead of the iterative undistortion's microseconds.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/point_rectifier.h"

namespace quad::vision {

class RectifyTable {
 public:
  RectifyTable() = default;
  RectifyTable(const PointRectifier& rectifier, cv::Size image_size, int step = 2);

  cv::Size image_size() const { return size_; }
  cv::Point2f map(cv::Point2f raw) const;
  void map(const std::vector<cv::Point2f>& raw, std::vector<cv::Point2f>& rectified) const;

 private:
  cv::Size size_;
  int step_ = 2;
  int cols_ = 0, rows_ = 0;   // grid nodes
  std::vector<cv::Point2f> nodes_;
};

}  // namespace quad::vision
