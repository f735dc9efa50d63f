#include "quad/vision/rectify_table.h"

#include <algorithm>
#include <cmath>

namespace quad::vision {

RectifyTable::RectifyTable(const PointRectifier& rectifier, cv::Size image_size, int step)
    : size_(image_size), step_(step) {
  // Nodes cover the image plus one cell beyond each edge (contour points may sit on the last pixel).
  cols_ = image_size.width / step + 3;
  rows_ = image_size.height / step + 3;
  std::vector<cv::Point> raw;
  raw.reserve(static_cast<size_t>(cols_) * rows_);
  for (int r = 0; r < rows_; ++r) {
    for (int c = 0; c < cols_; ++c) raw.emplace_back((c - 1) * step, (r - 1) * step);
  }
  rectifier.apply(raw, nodes_);
}

cv::Point2f RectifyTable::map(cv::Point2f raw) const {
  const float gx = std::clamp(raw.x / step_ + 1.0f, 0.0f, cols_ - 1.001f);
  const float gy = std::clamp(raw.y / step_ + 1.0f, 0.0f, rows_ - 1.001f);
  const int x0 = static_cast<int>(gx), y0 = static_cast<int>(gy);
  const float fx = gx - x0, fy = gy - y0;
  const cv::Point2f* n = &nodes_[static_cast<size_t>(y0) * cols_ + x0];
  const cv::Point2f top = n[0] * (1.0f - fx) + n[1] * fx;
  const cv::Point2f bottom = n[cols_] * (1.0f - fx) + n[cols_ + 1] * fx;
  return top * (1.0f - fy) + bottom * fy;
}

void RectifyTable::map(const std::vector<cv::Point2f>& raw, std::vector<cv::Point2f>& rectified) const {
  rectified.resize(raw.size());
  for (size_t i = 0; i < raw.size(); ++i) rectified[i] = map(raw[i]);
}

}  // namespace quad::vision
