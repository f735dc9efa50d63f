// The star's full pose from its outline in both rectified views: the contour moved onto the grey-level
// edge (sub-pixel) and split into its eight edges, whose intersections are the vertices; the vertices
// matched left to right and triangulated; a rigid fit (Kabsch) of the star model to them starts a
// Gauss-Newton fit of rotation, position and size, first to the 32 rectified vertex coordinates (u, v in
// each view), then to the distances of the edge points from the projected star edges. The inverse normal
// matrix times the edge points' error variance is the covariance.
//
// Star axes (docs/mavlink.md, "Star pose"): origin at the centre, z normal to the star pointing away
// from the cameras (into the floor), x through a tip, y = z × x through the next tip. The star is
// 4-fold symmetric: the tip that is x is chosen where the pose is expressed in the body frame
// (star_attitude_in_body: the tip nearest the vehicle's forward axis).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/stereo_calibration.h"

namespace quad::vision {

struct StarPoseSettings {
  double inner_ratio = 0.4;           // inner vertex radius / tip radius of the star model
  double tip_radius_m = 0.20;         // the marker's size: the fit's start value, and size_ratio's unit
  // Floor of the edge-point error the covariance assumes. The residual scatter (~0.06 px on clean
  // images) misses the mid-level crossing's bias, which depends on the edge's sub-pixel phase and is
  // the same for neighbouring points: ~0.15 px.
  double min_edge_sigma_px = 0.15;
  // A fit worse than this (8 vertices, both views) is no pose. Far off the axis the estimated lens model
  // is extrapolated and a good fit still has 1.5–3 px; the fitted size (StarPose::size_ratio) checks it.
  double max_rms_px = 3.0;
};

struct StarPose {
  bool valid = false;
  cv::Matx33d R_CS = cv::Matx33d::eye();       // star axes (columns) in the left camera frame
  cv::Vec3d t_C;                               // star centre in the left camera frame, metres
  cv::Matx33d attitude_cov_C = cv::Matx33d::zeros();  // rad², small rotation of the star, left camera axes
  cv::Matx33d position_cov_C = cv::Matx33d::zeros();  // m²
  double size_ratio = 1.0;                     // fitted tip radius / tip_radius_m
  double rms_px = 0.0;                         // vertex reprojection RMS after the fit
  double edge_sigma_px = 0.0;                  // the edge-point error the covariance assumes
  // The vertices of that view came from the outline's radius (octagon by the farthest and nearest
  // points), not from its polygon: the polygon's fit was beyond max_rms_px.
  bool left_vertices_by_radius = false, right_vertices_by_radius = false;
};

// The disparity gradient (rectified pixels per rectified pixel, along x and y) of the plane through
// t_C with normal R_CS's z axis (left camera frame): the star's plane as the two views see it.
cv::Vec2d plane_disparity_gradient(const cv::Matx33d& R_CS, const cv::Vec3d& t_C, const StereoCalibration& calibration);

// Bilinear grey value at (x, y) of the 8-bit image at `data` (`step` bytes per row), a point whose
// 2 × 2 neighbourhood lies inside the image (no checks).
inline double bilinear_inside(const uint8_t* data, size_t step, double x, double y) {
  const int ix = static_cast<int>(x), iy = static_cast<int>(y);  // truncation: the floor for x, y ≥ 0
  const double fx = x - ix, fy = y - iy;
  const uint8_t* r0 = data + iy * step;
  const uint8_t* r1 = r0 + step;
  return (1 - fy) * ((1 - fx) * r0[ix] + fx * r0[ix + 1]) + fy * ((1 - fx) * r1[ix] + fx * r1[ix + 1]);
}

// Bilinear grey value of an 8-bit image at a raw point, or −1 outside the image. Inline: the edge
// searches call it some thirty times per edge point.
inline double grey_at(const cv::Mat& gray, cv::Point2d p) {
  if (!(p.x >= 0.0 && p.y >= 0.0)) return -1.0;
  if (static_cast<int>(p.x) + 1 >= gray.cols || static_cast<int>(p.y) + 1 >= gray.rows) return -1.0;
  return bilinear_inside(gray.data, gray.step[0], p.x, p.y);
}

// The contour's points moved onto the grey-level edge: along the contour's normal, to where the profile
// crosses the middle between its darkest and brightest values within ±3 px, then to where the profile's
// area within ±2 px of that crossing puts the step (sub-pixel, raw pixels).
std::vector<cv::Point2f> subpixel_edges(const cv::Mat& gray, const std::vector<cv::Point>& contour);

// The grey-level edge near the raw point `p` along the unit `normal`, as subpixel_edges finds it for
// one contour point: false when the profile within ±3 px has no step of more than 10 grey levels or
// its mid-level crossing is farther than `max_offset_px` from p.
bool edge_near(const cv::Mat& gray, const cv::Point2d& p, const cv::Point2d& normal, cv::Point2d& edge,
               double max_offset_px);

// One camera's map between raw and rectified pixels, for points already known to within a pixel or so:
// Newton steps on the forward map (rectified → raw: the rectifying rotation undone, then OpenCV's lens
// model) with its analytic Jacobian, far cheaper than cv::undistortPoints' fixed-point iterations from
// scratch.
class NearRectifier {
 public:
  NearRectifier(const StereoCalibration& calibration, int camera);
  cv::Point2d raw(const cv::Point2d& rectified) const;
  // The rectified point whose raw pixel is `raw`, starting from `guess`.
  cv::Point2d rectified(const cv::Point2d& raw, cv::Point2d guess) const;

 private:
  // raw() and its Jacobian ∂raw/∂rectified (rows: raw x, raw y).
  cv::Point2d raw(const cv::Point2d& rectified, cv::Matx22d& jacobian) const;
  // Normalised camera coordinates → raw pixel (and its Jacobian when asked).
  cv::Point2d pixel(double x, double y, cv::Matx22d* jacobian) const;

  cv::Matx33d K_;
  cv::Vec<double, 5> D_;
  cv::Matx33d back_;  // rectified pixel → ray in the camera frame: Rᵀ·(P's left 3x3)⁻¹
};

// The eight vertices of a star contour (rectified pixels, in contour order, a tip first), each the
// intersection of the lines fitted to its two edges. False when the contour is not an 8-gon.
bool find_star_vertices(const std::vector<cv::Point2f>& contour, std::array<cv::Point2d, 8>& vertices);

// The pose from the two rectified contours of one star (StarCandidate::rectified).
StarPose estimate_star_pose(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right,
                            const StereoCalibration& calibration, const StarPoseSettings& settings);

// The eight vertices of the star a pose places, in each view's rectified pixels ([0] left, [1] right;
// vertex 0 a tip, vertex k + 1 the next counter-clockwise about the star's z, as in the fit).
std::array<std::array<cv::Point2d, 8>, 2> projected_star(const StarPose& pose, const StereoCalibration& calibration,
                                                         const StarPoseSettings& settings);

// Edge points of both views, each on a known edge: [view][k] on the edge from vertex k to vertex k + 1
// of projected_star (rectified pixels).
using StarEdgePoints = std::array<std::array<std::vector<cv::Point2f>, 8>, 2>;

// The edge fit of estimate_star_pose again, from `start`, to edge points already assigned to their
// edges; then once more without the points farther from their edge than 3 robust σ (edges of texture
// or of a fault band found instead of the star's). Invalid when a fit fails; keeps start's vertex RMS.
StarPose refit_star_pose(const StarPose& start, const StarEdgePoints& points, const StereoCalibration& calibration,
                         const StarPoseSettings& settings);

// Star axes in the body frame, R_BS = R_BC · R_CS, with the 4-fold symmetry resolved: x is the tip
// nearest the body's forward axis.
cv::Matx33d star_attitude_in_body(const cv::Matx33d& R_BC, const cv::Matx33d& R_CS);

// Hamilton quaternion (w, x, y, z) of a rotation matrix, w >= 0.
cv::Vec4d quaternion_from_rotation(const cv::Matx33d& R);

}  // namespace quad::vision
