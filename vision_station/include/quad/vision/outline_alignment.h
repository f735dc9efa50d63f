// The map that lays one view's rectified star outline onto the other's. Both views see the same
// planar star from points a baseline apart: after rectification a point's disparity on a plane is an
// affine function of its image position (1/Z is affine in the image coordinates of a plane, eq. 8.3
// d = f b / Z), and its row is the same in both views. So the right outline maps onto the left by a
// disparity that varies linearly across it (the star's tilt) plus a row shift (a calibration or timing
// error), and that map found from the whole outline, with the points that do not fit left out, is the
// stereo correspondence that a local defect of one view (a shadow edge across a tip, a merged blob, a
// fault band) cannot move. The centroid of that view moves with the defect's area.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace quad::vision {

struct OutlineAlignment {
  bool valid = false;
  // left ≈ right + shift at the right outline's mean point `origin`; the horizontal shift grows by
  // gradient · (right − origin) away from it (rectified pixels).
  cv::Point2d shift;
  cv::Point2d origin;
  cv::Vec2d gradient{0.0, 0.0};
  double residual_px = 0.0;   // RMS point-to-outline distance of the inliers after the map
  double inlier_fraction = 0.0;

  // The shift (left − right) at the right point that maps onto the left point `left`.
  cv::Point2d shift_at(const cv::Point2d& left) const;
};

// Point-to-line iterations from `initial_shift` (the centroids' difference, no gradient): each right
// point is matched to the nearest left point and measured along the left outline's normal there; the
// points farther than three robust standard deviations (at least `min_gate_px`) are left out of each
// step. No alignment when the disparity gradient exceeds `max_gradient` (no plane in view bends the
// disparity that fast: another shape).
OutlineAlignment align_outlines(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right,
                                const cv::Point2d& initial_shift, double min_gate_px = 0.75,
                                double max_gradient = 0.5);

}  // namespace quad::vision
