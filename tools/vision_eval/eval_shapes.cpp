#include "eval_shapes.h"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace vision_eval {
namespace {

Outline alternating_star(cv::Point2d centre, int points, double outer, double inner, double yaw) {
  Outline o;
  for (int i = 0; i < 2 * points; ++i) {
    const double a = yaw + i * CV_PI / points;
    const double r = i % 2 == 0 ? outer : inner;
    o.emplace_back(centre.x + r * std::cos(a), centre.y + r * std::sin(a));
  }
  return o;
}

Outline rotated(const Outline& local, cv::Point2d centre, double yaw) {
  Outline o;
  const double c = std::cos(yaw), s = std::sin(yaw);
  for (const cv::Point2d& p : local) o.emplace_back(centre.x + c * p.x - s * p.y, centre.y + s * p.x + c * p.y);
  return o;
}

}  // namespace

Outline four_point_star(cv::Point2d centre, double tip, double yaw) {
  return alternating_star(centre, 4, tip, 0.4 * tip, yaw);
}

Outline five_point_star(cv::Point2d centre, double tip, double inner_ratio, double yaw) {
  return alternating_star(centre, 5, tip, inner_ratio * tip, yaw);
}

Outline square(cv::Point2d centre, double side, double yaw) {
  const double h = 0.5 * side;
  return rotated({{-h, -h}, {h, -h}, {h, h}, {-h, h}}, centre, yaw);
}

Outline disc(cv::Point2d centre, double radius) {
  Outline o;
  for (int i = 0; i < 180; ++i) {
    const double a = i * 2.0 * CV_PI / 180.0;
    o.emplace_back(centre.x + radius * std::cos(a), centre.y + radius * std::sin(a));
  }
  return o;
}

Outline plus_cross(cv::Point2d centre, double arm, double width, double yaw) {
  const double a = arm, w = 0.5 * width;
  return rotated({{w, -w}, {a, -w}, {a, w}, {w, w}, {w, a}, {-w, a}, {-w, w}, {-a, w}, {-a, -w}, {-w, -w},
                  {-w, -a}, {w, -a}},
                 centre, yaw);
}

double outline_radius(const Outline& outline, cv::Point2d centre) {
  double r = 0.0;
  for (const cv::Point2d& p : outline) r = std::max(r, cv::norm(p - centre));
  return r;
}

CoverageCanvas draw_outlines(const std::vector<Outline>& outlines, double metres_per_px) {
  CoverageCanvas canvas;
  canvas.metres_per_px = metres_per_px;
  cv::Point2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (const Outline& o : outlines) {
    for (const cv::Point2d& p : o) {
      lo = cv::Point2d(std::min(lo.x, p.x), std::min(lo.y, p.y));
      hi = cv::Point2d(std::max(hi.x, p.x), std::max(hi.y, p.y));
    }
  }
  if (outlines.empty()) lo = hi = cv::Point2d(0, 0);
  const double pad = 4 * metres_per_px;
  canvas.origin = lo - cv::Point2d(pad, pad);
  const int w = static_cast<int>(std::ceil((hi.x - lo.x + 2 * pad) / metres_per_px)) + 1;
  const int h = static_cast<int>(std::ceil((hi.y - lo.y + 2 * pad) / metres_per_px)) + 1;
  cv::Mat ink(h, w, CV_8U, cv::Scalar(0));
  constexpr int kShift = 4;
  for (const Outline& o : outlines) {
    std::vector<cv::Point> pts;
    for (const cv::Point2d& p : o) {
      pts.emplace_back(cvRound((p.x - canvas.origin.x) / metres_per_px * (1 << kShift)),
                       cvRound((p.y - canvas.origin.y) / metres_per_px * (1 << kShift)));
    }
    cv::fillPoly(ink, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(255), cv::LINE_AA, kShift);
  }
  ink.convertTo(canvas.coverage, CV_32F, 1.0 / 255.0);
  return canvas;
}

CoverageCanvas draw_chessboard(int cols, int rows, double square_m, double metres_per_px) {
  std::vector<Outline> squares;
  // Squares (i, j) for i in [0, cols), j in [0, rows); the first inner corner is the far corner of (0, 0).
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      if ((i + j) % 2 != 0) continue;
      const double x0 = (i - 1) * square_m, y0 = (j - 1) * square_m;
      squares.push_back({{x0, y0}, {x0 + square_m, y0}, {x0 + square_m, y0 + square_m}, {x0, y0 + square_m}});
    }
  }
  return draw_outlines(squares, metres_per_px);
}

}  // namespace vision_eval
