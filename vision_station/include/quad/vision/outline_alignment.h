// The shift that lays one view's rectified star outline onto the other's. Both views see the same
// planar star from points a baseline apart: after rectification the two outlines differ by a
// translation (the disparity and the row difference) and a shear of a few per cent (the star's tilt),
// so the translation found from the whole outline, with the points that do not fit left out, is the
// stereo correspondence that a local defect of one view (a shadow edge across a tip, a merged blob, a
// fault band) cannot move. The centroid of that view moves with the defect's area.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace quad::vision {

struct OutlineAlignment {
  bool valid = false;
  cv::Point2d shift;          // left ≈ right + shift (rectified pixels)
  double residual_px = 0.0;   // RMS point-to-outline distance of the inliers after the shift
  double inlier_fraction = 0.0;
};

// Point-to-line iterations from `initial_shift` (the centroids' difference): each right point is
// matched to the nearest left point and measured along the left outline's normal there; the points
// farther than three robust standard deviations (at least `min_gate_px`) are left out of each step.
OutlineAlignment align_outlines(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right,
                                const cv::Point2d& initial_shift, double min_gate_px = 0.75);

}  // namespace quad::vision
