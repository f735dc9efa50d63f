#include "quad/vision/chessboard_calibration.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace quad::vision {
namespace {

int covered_cells(const std::vector<std::vector<cv::Point2f>>& views, cv::Size size, int cells) {
  std::set<int> hit;
  for (const auto& view : views) {
    for (const cv::Point2f& p : view) {
      const int cx = std::clamp(static_cast<int>(p.x * cells / size.width), 0, cells - 1);
      const int cy = std::clamp(static_cast<int>(p.y * cells / size.height), 0, cells - 1);
      hit.insert(cy * cells + cx);
    }
  }
  return static_cast<int>(hit.size());
}

// The largest angle off the camera's axis of any corner seen, through the calibrated lens (iterated as
// PointRectifier does: OpenCV's default of 5 iterations is off at a wide lens's edge).
double widest_off_axis(const std::vector<std::vector<cv::Point2f>>& views, const CameraIntrinsics& camera) {
  double widest = 0.0;
  for (const std::vector<cv::Point2f>& corners : views) {
    std::vector<cv::Point2f> rays;
    cv::undistortPoints(corners, rays, camera.K, camera.D, cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 40, 1e-10));
    for (const cv::Point2f& r : rays) widest = std::max(widest, std::atan(std::hypot(double{r.x}, double{r.y})));
  }
  return widest;
}

}  // namespace

std::vector<cv::Point3f> board_points(const ChessboardSpec& board) {
  std::vector<cv::Point3f> points;
  for (int r = 0; r < board.inner_corners.height; ++r) {
    for (int c = 0; c < board.inner_corners.width; ++c) {
      points.emplace_back(static_cast<float>(c * board.square_m), static_cast<float>(r * board.square_m), 0.0f);
    }
  }
  return points;
}

std::optional<std::vector<cv::Point2f>> find_chessboard(const cv::Mat& gray, const ChessboardSpec& board) {
  // The sector-based detector finds the board without the classic detector's pathological run times
  // (tens of seconds) on strongly distorted, tilted boards; cornerSubPix then refines each saddle point
  // (SB's own estimate leaves ~0.35 px RMS, which biases the focal length by ~1.5 %).
  std::vector<cv::Point2f> corners;
  if (!cv::findChessboardCornersSB(gray, board.inner_corners, corners, cv::CALIB_CB_NORMALIZE_IMAGE)) {
    return std::nullopt;
  }
  cv::cornerSubPix(gray, corners, cv::Size(4, 4), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-3));
  return corners;
}

StereoCalibrationResult calibrate_stereo(const std::vector<std::vector<cv::Point2f>>& left,
                                         const std::vector<std::vector<cv::Point2f>>& right, cv::Size image_size,
                                         const ChessboardSpec& board, const CalibrationRequirements& req) {
  if (left.size() != right.size()) throw std::invalid_argument("calibrate_stereo: left and right view counts differ");
  const int n = static_cast<int>(left.size());
  if (n < req.min_pairs) {
    throw CalibrationSetError("only " + std::to_string(n) + " views show the whole board in both cameras; capture at least " +
                              std::to_string(req.min_pairs) + " (15-20 recommended), board tilted in different "
                              "directions and placed across the whole image");
  }
  const int total_cells = req.coverage_cells * req.coverage_cells;
  for (int camera = 0; camera < 2; ++camera) {
    const int covered = covered_cells(camera == 0 ? left : right, image_size, req.coverage_cells);
    if (covered < req.min_covered_cells) {
      throw CalibrationSetError(std::string("the board corners reach only ") + std::to_string(covered) + " of " +
                                std::to_string(total_cells) + " image regions in the " + (camera == 0 ? "left" : "right") +
                                " camera (need " + std::to_string(req.min_covered_cells) +
                                "); capture views with the board near the edges and corners of both images");
    }
  }

  // The chessboard detector may report a view's corners from either end (180° ambiguity). The cameras
  // look the same way, so the first-to-last corner direction must agree between left and right.
  std::vector<std::vector<cv::Point2f>> right_aligned = right;
  for (int i = 0; i < n; ++i) {
    if (left[i].size() != right[i].size() || left[i].empty()) {
      throw std::invalid_argument("calibrate_stereo: view " + std::to_string(i) + " has different corner counts");
    }
    const cv::Point2f dl = left[i].back() - left[i].front();
    const cv::Point2f dr = right[i].back() - right[i].front();
    if (dl.dot(dr) < 0.0f) std::reverse(right_aligned[i].begin(), right_aligned[i].end());
  }

  const std::vector<std::vector<cv::Point3f>> object(static_cast<size_t>(n), board_points(board));
  StereoRig rig;
  rig.image_size = image_size;
  cv::Mat K1, D1, K2, D2;
  std::vector<cv::Mat> rvecs, tvecs;
  StereoCalibrationResult result;
  result.pairs = n;
  result.rms_left_px = cv::calibrateCamera(object, left, image_size, K1, D1, rvecs, tvecs);
  // Focal length is only observable from tilted boards: fronto-parallel views confound it with distance.
  int tilted = 0;
  double max_tilt = 0.0;
  for (const cv::Mat& rvec : rvecs) {
    cv::Matx33d R;
    cv::Rodrigues(rvec, R);
    const double tilt = std::acos(std::clamp(std::fabs(R(2, 2)), 0.0, 1.0)) * 180.0 / CV_PI;
    max_tilt = std::max(max_tilt, tilt);
    if (tilt >= req.min_tilt_deg) ++tilted;
  }
  if (tilted < req.min_tilted_views) {
    throw CalibrationSetError("only " + std::to_string(tilted) + " views have the board tilted by " +
                              std::to_string(static_cast<int>(req.min_tilt_deg)) + " deg or more (largest " +
                              std::to_string(static_cast<int>(max_tilt)) + " deg; need " +
                              std::to_string(req.min_tilted_views) +
                              "); capture the board tilted by 20-40 deg towards different sides");
  }
  result.rms_right_px = cv::calibrateCamera(object, right_aligned, image_size, K2, D2, rvecs, tvecs);
  cv::Mat R, T, E, F;
  result.rms_stereo_px = cv::stereoCalibrate(object, left, right_aligned, K1, D1, K2, D2, image_size, R, T, E, F,
                                             cv::CALIB_FIX_INTRINSIC);
  const double worst = std::max({result.rms_left_px, result.rms_right_px, result.rms_stereo_px});
  if (worst > req.max_rms_px) {
    char message[320];
    std::snprintf(message, sizeof message,
                  "reprojection RMS too large (left %.2f px, right %.2f px, stereo %.2f px; limit %.2f): some "
                  "corners are wrong or the left and right images were not taken at the same time; capture the "
                  "whole board with a white margin in both images, holding it still",
                  result.rms_left_px, result.rms_right_px, result.rms_stereo_px, req.max_rms_px);
    throw CalibrationSetError(message);
  }
  rig.left = CameraIntrinsics{cv::Matx33d(K1), cv::Vec<double, 5>(D1.reshape(1, 5))};
  rig.right = CameraIntrinsics{cv::Matx33d(K2), cv::Vec<double, 5>(D2.reshape(1, 5))};
  rig.R = cv::Matx33d(R);
  rig.T = cv::Vec3d(T);
  if (!(rig.T[0] < 0.0)) {
    throw CalibrationSetError("the right camera is not to the right of the left one (T_x = " + std::to_string(rig.T[0]) +
                              " m): swap the left and right images or cameras");
  }
  result.calibration = rectify(rig);
  result.widest_off_axis_rad = widest_off_axis(left, rig.left);
  return result;
}

}  // namespace quad::vision
