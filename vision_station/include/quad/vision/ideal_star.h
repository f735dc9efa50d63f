// The landing marker: a four-pointed star, dark on a light floor (thesis sec. 8.1, fig. 8.4).
#pragma once

#include <vector>

#include <opencv2/core.hpp>

namespace quad::vision {

struct StarShape {
  double tip_radius = 0.20;    // R, metres: 0.40 m tip to tip
  double inner_ratio = 0.4;    // inner vertex radius / R
};

// The eight vertices in the marker's own plane (metres, counter-clockwise from the tip on +x): tips at
// 0°, 90°, 180°, 270° of radius R, inner vertices at 45°, 135°, 225°, 315° of radius inner_ratio·R.
std::vector<cv::Point2d> star_vertices(const StarShape& shape);

// The ideal contour used for the Hu-moment comparison (filter 5), in pixels (scale is irrelevant to
// Hu invariants but keeps the polygon well conditioned).
std::vector<cv::Point> ideal_star_contour(double inner_ratio);

}  // namespace quad::vision
