// A star found in one view sought in the other by its outline. When the other view's outline is lost
// (merged with a shadow or dark texture, cut by a fault band, torn by RF snow: no contour of the star's
// shape there at any contrast level), its edges are still there along most of the outline. The found
// star's sub-pixel edge points, shifted by a trial disparity and row, are tested in the other view for
// a step of the star's polarity (darker inside) and of a good part of its contrast; the best shift over
// the guided search's disparities and a few rows places the outline, and each point is then moved onto
// the other view's grey-level edge along its normal (star_pose.h edge_near). What is found is only a
// candidate: the locator still requires the two outlines to lay onto each other (outline_alignment.h).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/star_pose.h"

namespace quad::vision {

struct OutlineTransferSearch {
  double min_shift_x = 0.0, max_shift_x = 0.0;  // other ≈ found + shift (rectified pixels), searched in 1-px steps
  double max_shift_y = 3.0;                     // rows searched either side of 0, in 1-px steps
  double min_edge_fraction = 0.6;               // of the outline's points with the star's edge at the best shift
  double min_contrast_fraction = 0.4;           // an edge is a step of at least this part of the star's contrast
  // No star where the outline at the best shift comes nearer the other image's edge than this (raw
  // pixels): a star cut by the edge is never taken, and its visible part can match most of the outline.
  double edge_margin_px = 3.0;
};

struct TransferredOutline {
  bool found = false;
  cv::Point2d shift;                  // the best trial shift (rectified pixels)
  double edge_fraction = 0.0;         // of the points with the star's edge there at that shift
  std::vector<cv::Point> contour;     // the other view: raw pixels just inside its edge, in outline order
  std::vector<cv::Point2f> rectified; // the same points, rectified
  std::vector<cv::Point2f> edges;     // the other view's sub-pixel edge points, rectified
};

// `edges`: the found star's rectified sub-pixel edge points in outline order (StereoStarLocator's
// rectified_edges); `found_gray`/`found_view`: its view; `other_gray`/`other_view`: the view to search.
TransferredOutline transfer_outline(const std::vector<cv::Point2f>& edges, const cv::Mat& found_gray,
                                    const NearRectifier& found_view, const cv::Mat& other_gray,
                                    const NearRectifier& other_view, const OutlineTransferSearch& search);

}  // namespace quad::vision
