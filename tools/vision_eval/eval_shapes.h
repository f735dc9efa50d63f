// Outlines drawn on the floor (metres, plane z = 0): the landing star, the decoys, the calibration
// chessboard, and a canvas that holds their anti-aliased coverage for rendering.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace vision_eval {

// A filled polygon on the plane.
using Outline = std::vector<cv::Point2d>;

// The landing marker: a four-pointed star, tips at radius `tip` (0.20 m: 0.40 m tip to tip), the four
// inner corners at 0.4 × tip, first tip at angle `yaw`.
Outline four_point_star(cv::Point2d centre, double tip, double yaw);
Outline five_point_star(cv::Point2d centre, double tip, double inner_ratio, double yaw);
Outline square(cv::Point2d centre, double side, double yaw);
Outline disc(cv::Point2d centre, double radius);
Outline plus_cross(cv::Point2d centre, double arm, double width, double yaw);

double outline_radius(const Outline& outline, cv::Point2d centre);  // largest distance from centre

// Coverage (0..1, CV_32F) of polygons on a patch of the plane, sampled every `metres_per_px`.
struct CoverageCanvas {
  cv::Mat coverage;
  cv::Point2d origin;  // plane point of canvas pixel (0, 0)
  double metres_per_px = 0.001;
};

// The polygons drawn with 1/16-px vertex precision and anti-aliased edges.
CoverageCanvas draw_outlines(const std::vector<Outline>& outlines, double metres_per_px);

// A chessboard of cols × rows squares of `square` metres (inner corners (cols−1) × (rows−1)) with its
// first inner corner at the plane origin: coverage 1 = black (the plane around it is the white margin).
CoverageCanvas draw_chessboard(int cols, int rows, double square, double metres_per_px);

}  // namespace vision_eval
