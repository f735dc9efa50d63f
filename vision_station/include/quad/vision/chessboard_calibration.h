// Stereo calibration from chessboard views (thesis sec. 7.4): per-camera calibrateCamera, then
// stereoCalibrate with the intrinsics fixed, then stereoRectify. A set that is too small or degenerate is
// refused with a message that says what to capture.
#pragma once

#include <optional>
#include <stdexcept>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/stereo_calibration.h"

namespace quad::vision {

struct ChessboardSpec {
  cv::Size inner_corners{9, 6};  // inner corners per row and column
  double square_m = 0.025;       // side of one square, metres
};

// The inner corners in the board's own frame (x along a row, y down the columns, z = 0), row by row as
// cv::findChessboardCorners returns them.
std::vector<cv::Point3f> board_points(const ChessboardSpec& board);

// Thrown when the views cannot give a trustworthy calibration; what() says what to capture.
struct CalibrationSetError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct CalibrationRequirements {
  int min_pairs = 10;          // views seen by both cameras
  int coverage_cells = 5;      // the image is split into cells × cells regions ...
  int min_covered_cells = 15;  // ... of which the corners must reach this many, in each camera
  double min_tilt_deg = 15.0;  // at least min_tilted_views boards tilted this much from fronto-parallel
  int min_tilted_views = 3;
  double max_rms_px = 1.0;     // reprojection RMS above this means bad corners or unsynchronised pairs
};

struct StereoCalibrationResult {
  StereoCalibration calibration;
  double rms_left_px = 0.0;    // per-camera reprojection RMS
  double rms_right_px = 0.0;
  double rms_stereo_px = 0.0;  // stereoCalibrate RMS
  int pairs = 0;
  // The largest angle off the left camera's axis at which a corner was seen: beyond it the lens model is
  // extrapolated (LocatorSettings::max_off_axis_rad).
  double widest_off_axis_rad = 0.0;
};

// Chessboard inner corners, sub-pixel refined; nullopt when the board is not found whole.
std::optional<std::vector<cv::Point2f>> find_chessboard(const cv::Mat& gray, const ChessboardSpec& board);

// Calibrates from corner sets of the same views (left[i] and right[i] taken together).
StereoCalibrationResult calibrate_stereo(const std::vector<std::vector<cv::Point2f>>& left,
                                         const std::vector<std::vector<cv::Point2f>>& right, cv::Size image_size,
                                         const ChessboardSpec& board,
                                         const CalibrationRequirements& requirements = CalibrationRequirements());

}  // namespace quad::vision
