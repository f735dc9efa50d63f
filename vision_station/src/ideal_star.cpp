#include "quad/vision/ideal_star.h"

#include <cmath>

namespace quad::vision {

std::vector<cv::Point2d> star_vertices(const StarShape& shape) {
  std::vector<cv::Point2d> v;
  v.reserve(8);
  for (int i = 0; i < 8; ++i) {
    const double angle = i * CV_PI / 4.0;
    const double radius = (i % 2 == 0) ? shape.tip_radius : shape.inner_ratio * shape.tip_radius;
    v.emplace_back(radius * std::cos(angle), radius * std::sin(angle));
  }
  return v;
}

std::vector<cv::Point> ideal_star_contour(double inner_ratio) {
  constexpr double kScale = 1000.0;
  std::vector<cv::Point> contour;
  for (const cv::Point2d& p : star_vertices(StarShape{kScale, inner_ratio})) {
    contour.emplace_back(cvRound(p.x + kScale), cvRound(p.y + kScale));
  }
  return contour;
}

}  // namespace quad::vision
