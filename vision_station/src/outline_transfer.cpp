#include "quad/vision/outline_transfer.h"

#include <algorithm>
#include <cmath>

namespace quad::vision {
namespace {

// Points tested per trial shift: the outline's shape is carried by far fewer than its edge points.
constexpr size_t kSearchPoints = 64;
// The step is measured this far either side of the edge (raw pixels): beyond a blurred edge's ramp.
constexpr double kStepReach = 1.5;

cv::Point2d unit(const cv::Point2d& v) {
  const double length = std::hypot(v.x, v.y);
  return length > 0.0 ? v / length : cv::Point2d(0.0, 0.0);
}

// Grey-level step across the raw point p along the raw outward normal n (floor minus star: positive for
// the star's polarity), or a large negative value where the samples leave the image.
double step_across(const cv::Mat& gray, const cv::Point2d& p, const cv::Point2d& n) {
  const double outside = grey_at(gray, p + kStepReach * n), inside = grey_at(gray, p - kStepReach * n);
  return outside < 0.0 || inside < 0.0 ? -1e9 : outside - inside;
}

}  // namespace

TransferredOutline transfer_outline(const std::vector<cv::Point2f>& edges, const cv::Mat& found_gray,
                                    const NearRectifier& found_view, const cv::Mat& other_gray,
                                    const NearRectifier& other_view, const OutlineTransferSearch& search) {
  TransferredOutline result;
  const size_t n = edges.size();
  if (n < 16) return result;
  // Outward normals in rectified pixels: the tangent turned towards the outside, whose side the
  // outline's orientation (the sign of its shoelace area) gives; the star is not convex, so not the
  // direction away from its centre.
  double twice_area = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2f& a = edges[i];
    const cv::Point2f& b = edges[(i + 1) % n];
    twice_area += static_cast<double>(a.x) * b.y - static_cast<double>(b.x) * a.y;
  }
  const double side = twice_area > 0.0 ? 1.0 : -1.0;
  std::vector<cv::Point2d> normal(n);
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2d t = cv::Point2d(edges[(i + 2) % n]) - cv::Point2d(edges[(i + n - 2) % n]);
    normal[i] = side * unit(cv::Point2d(t.y, -t.x));
  }
  // The raw outward normal of a rectified point with rectified normal m, in one view.
  auto raw_normal = [](const NearRectifier& view, const cv::Point2d& raw, const cv::Point2d& q, const cv::Point2d& m) {
    return unit(view.raw(q + m) - raw);
  };

  // The star's contrast in its own view: the median step across its edge.
  const size_t stride = std::max<size_t>((n + kSearchPoints - 1) / kSearchPoints, 1);
  std::vector<size_t> sampled;
  for (size_t i = 0; i < n; i += stride) sampled.push_back(i);
  std::vector<double> steps;
  for (size_t i : sampled) {
    const cv::Point2d q(edges[i]);
    const cv::Point2d raw = found_view.raw(q);
    steps.push_back(step_across(found_gray, raw, raw_normal(found_view, raw, q, normal[i])));
  }
  std::nth_element(steps.begin(), steps.begin() + static_cast<std::ptrdiff_t>(steps.size() / 2), steps.end());
  const double contrast = steps[steps.size() / 2];
  if (!(contrast > 10.0)) return result;
  const double min_step = search.min_contrast_fraction * contrast;

  // The other view's raw normals barely change over the searched shifts: taken once, at the middle one.
  const cv::Point2d middle(0.5 * (search.min_shift_x + search.max_shift_x), 0.0);
  std::vector<cv::Point2d> other_normal(sampled.size());
  for (size_t k = 0; k < sampled.size(); ++k) {
    const cv::Point2d q = cv::Point2d(edges[sampled[k]]) + middle;
    other_normal[k] = raw_normal(other_view, other_view.raw(q), q, normal[sampled[k]]);
  }
  // Trial shifts: every column of the disparity range, rows nearest 0 first (so a tie keeps the row).
  size_t best_count = 0;
  cv::Point2d best;
  const int rows = static_cast<int>(std::floor(search.max_shift_y));
  for (int r = 0; r <= 2 * rows; ++r) {
    const double dy = (r % 2 == 0 ? 1.0 : -1.0) * ((r + 1) / 2);
    for (double dx = std::ceil(search.min_shift_x); dx <= search.max_shift_x; dx += 1.0) {
      size_t count = 0;
      for (size_t k = 0; k < sampled.size(); ++k) {
        const cv::Point2d raw = other_view.raw(cv::Point2d(edges[sampled[k]]) + cv::Point2d(dx, dy));
        if (step_across(other_gray, raw, other_normal[k]) >= min_step) ++count;
      }
      if (count > best_count) {
        best_count = count;
        best = cv::Point2d(dx, dy);
      }
    }
  }
  result.shift = best;
  result.edge_fraction = static_cast<double>(best_count) / static_cast<double>(sampled.size());
  if (result.edge_fraction < search.min_edge_fraction) return result;

  const cv::Rect2d inside_margin(search.edge_margin_px, search.edge_margin_px,
                                 other_gray.cols - 1 - 2.0 * search.edge_margin_px,
                                 other_gray.rows - 1 - 2.0 * search.edge_margin_px);
  for (size_t i = 0; i < n; ++i) {
    if (!inside_margin.contains(other_view.raw(cv::Point2d(edges[i]) + best))) return result;
  }

  // Every point onto the other view's edge. The contour keeps the predicted point where no edge is
  // found (the merged part), so that it stays a closed outline of the star's shape.
  size_t on_edge = 0;
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2d q = cv::Point2d(edges[i]) + best;
    const cv::Point2d raw = other_view.raw(q);
    const cv::Point2d m = raw_normal(other_view, raw, q, normal[i]);
    cv::Point2d edge;
    const bool found = step_across(other_gray, raw, m) >= min_step && edge_near(other_gray, raw, m, edge, 1.5);
    const cv::Point2d inside = (found ? edge : raw) - 0.7 * m;
    result.contour.emplace_back(cvRound(inside.x), cvRound(inside.y));
    result.rectified.emplace_back(other_view.rectified(inside, q));
    if (!found) continue;
    result.edges.emplace_back(other_view.rectified(edge, q));
    ++on_edge;
  }
  result.found = static_cast<double>(on_edge) >= search.min_edge_fraction * static_cast<double>(n);
  return result;
}

}  // namespace quad::vision
