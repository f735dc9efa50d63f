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

cv::Point2d OutlineAlignment::shift_at(const cv::Point2d& left) const {
  // left.x = right.x + shift.x + g0 (right.x − origin.x) + g1 (right.y − origin.y), left.y = right.y + shift.y
  const double right_y = left.y - shift.y;
  const double right_x =
      (left.x - shift.x + gradient[0] * origin.x - gradient[1] * (right_y - origin.y)) / (1.0 + gradient[0]);
  return {left.x - right_x, shift.y};
}

OutlineAlignment align_outlines(const std::vector<cv::Point2f>& left_points,
                                const std::vector<cv::Point2f>& right_points, const cv::Point2d& initial_shift,
                                double min_gate_px, double max_gradient) {
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
  cv::Point2d origin(0.0, 0.0);
  for (const cv::Point2d& p : right) origin += p;
  origin *= 1.0 / static_cast<double>(right.size());
  // Parameters: horizontal shift at the origin, row shift, and the disparity's gradient (x, y).
  cv::Vec4d x(initial_shift.x, initial_shift.y, 0.0, 0.0);
  auto mapped = [&](const cv::Point2d& p) {
    const cv::Point2d q = p - origin;
    return cv::Point2d(p.x + x[0] + x[2] * q.x + x[3] * q.y, p.y + x[1]);
  };
  std::vector<double> residual(right.size());
  std::vector<size_t> nearest(right.size());
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    for (size_t k = 0; k < right.size(); ++k) {
      const cv::Point2d p = mapped(right[k]);
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
    const double gate = std::max(3.0 * 1.4826 * median_of(magnitude), min_gate_px);
    // Gauss-Newton on the inliers' normal distances r: J = ∂r/∂x, (Σ Jᵀ J) δ = −Σ Jᵀ r.
    cv::Matx44d A = cv::Matx44d::zeros();
    cv::Vec4d b(0.0, 0.0, 0.0, 0.0);
    size_t inliers = 0;
    double sum2 = 0.0;
    for (size_t k = 0; k < right.size(); ++k) {
      if (std::fabs(residual[k]) > gate) continue;
      const cv::Point2d& m = normal[nearest[k]];
      const cv::Point2d q = right[k] - origin;
      const cv::Vec4d J(m.x, m.y, m.x * q.x, m.x * q.y);
      A += J * J.t();
      b -= residual[k] * J;
      sum2 += residual[k] * residual[k];
      ++inliers;
    }
    cv::Vec4d step;
    if (inliers < 8 || !cv::solve(A, b, step, cv::DECOMP_CHOLESKY)) return result;
    x += step;
    result.residual_px = std::sqrt(sum2 / static_cast<double>(inliers));
    result.inlier_fraction = static_cast<double>(inliers) / static_cast<double>(right.size());
    if (std::hypot(step[0], step[1]) < 0.005 && std::fabs(step[2]) + std::fabs(step[3]) < 1e-4) break;
  }
  if (!(std::fabs(x[2]) <= max_gradient && std::fabs(x[3]) <= max_gradient)) return result;
  result.valid = true;
  result.shift = cv::Point2d(x[0], x[1]);
  result.origin = origin;
  result.gradient = cv::Vec2d(x[2], x[3]);
  return result;
}

}  // namespace quad::vision
