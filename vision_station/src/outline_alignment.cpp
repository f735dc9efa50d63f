#include "quad/vision/outline_alignment.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace quad::vision {
namespace {

// Points per view: the outline's shape is carried by far fewer than its edge points, and the
// nearest-point search is quadratic in them.
constexpr size_t kMaxPoints = 96;
constexpr int kIterations = 8;

std::vector<cv::Point2d> subsample(const std::vector<cv::Point2f>& points) {
  const size_t stride = std::max<size_t>((points.size() + kMaxPoints - 1) / kMaxPoints, 1);
  std::vector<cv::Point2d> out;
  for (size_t i = 0; i < points.size(); i += stride) out.emplace_back(points[i].x, points[i].y);
  return out;
}

double median_of(std::vector<double> v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

OutlineAlignment align_outlines(const std::vector<cv::Point2f>& left_points,
                                const std::vector<cv::Point2f>& right_points, const cv::Point2d& initial_shift,
                                double min_gate_px) {
  OutlineAlignment result;
  const std::vector<cv::Point2d> left = subsample(left_points);
  const std::vector<cv::Point2d> right = subsample(right_points);
  const size_t n = left.size();
  if (n < 16 || right.size() < 16) return result;
  // The left outline's unit normal at each of its points (from its neighbours along the closed outline).
  std::vector<cv::Point2d> normal(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2d t = left[(i + 1) % n] - left[(i + n - 1) % n];
    const double len = std::hypot(t.x, t.y);
    normal[i] = len > 0.0 ? cv::Point2d(-t.y / len, t.x / len) : cv::Point2d(0.0, 0.0);
  }
  cv::Point2d shift = initial_shift;
  std::vector<double> residual(right.size());
  std::vector<size_t> nearest(right.size());
  double gate = std::numeric_limits<double>::infinity();
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    for (size_t k = 0; k < right.size(); ++k) {
      const cv::Point2d p = right[k] + shift;
      double best = std::numeric_limits<double>::infinity();
      for (size_t i = 0; i < n; ++i) {
        const cv::Point2d d = p - left[i];
        const double d2 = d.x * d.x + d.y * d.y;
        if (d2 < best) {
          best = d2;
          nearest[k] = i;
        }
      }
      residual[k] = normal[nearest[k]].dot(p - left[nearest[k]]);
    }
    std::vector<double> magnitude(residual.size());
    for (size_t k = 0; k < residual.size(); ++k) magnitude[k] = std::fabs(residual[k]);
    gate = std::max(3.0 * 1.4826 * median_of(magnitude), min_gate_px);
    // Least squares of the inliers' normal distances for the shift's correction: Σ n nᵀ δ = −Σ n r.
    cv::Matx22d A = cv::Matx22d::zeros();
    cv::Vec2d b(0.0, 0.0);
    size_t inliers = 0;
    double sum2 = 0.0;
    for (size_t k = 0; k < right.size(); ++k) {
      if (std::fabs(residual[k]) > gate) continue;
      const cv::Point2d& m = normal[nearest[k]];
      A += cv::Matx22d(m.x * m.x, m.x * m.y, m.x * m.y, m.y * m.y);
      b += cv::Vec2d(-m.x * residual[k], -m.y * residual[k]);
      sum2 += residual[k] * residual[k];
      ++inliers;
    }
    if (inliers < 8 || cv::determinant(A) <= 1e-9 * (A(0, 0) + A(1, 1)) * (A(0, 0) + A(1, 1))) return result;
    const cv::Vec2d step = A.inv() * b;
    shift += cv::Point2d(step[0], step[1]);
    result.residual_px = std::sqrt(sum2 / static_cast<double>(inliers));
    result.inlier_fraction = static_cast<double>(inliers) / static_cast<double>(right.size());
    if (std::hypot(step[0], step[1]) < 0.005) break;
  }
  result.valid = true;
  result.shift = shift;
  return result;
}

}  // namespace quad::vision
