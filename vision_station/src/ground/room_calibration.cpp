#include "quad/vision/ground/room_calibration.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>

#include <opencv2/calib3d.hpp>

namespace quad::vision::ground {
namespace {

// Camera centre in NED seen from one placement with the given corner order.
cv::Vec3d centre_from_placement(const std::vector<cv::Point2f>& corners, const FloorPlacement& placement,
                                const ChessboardSpec& board, const cv::Matx33d& K, const cv::Vec<double, 5>& D) {
  const std::vector<cv::Point3d> ned = placement_corners_ned(placement, board);
  cv::Vec3d rvec, tvec;
  cv::solvePnP(ned, corners, K, D, rvec, tvec, false, cv::SOLVEPNP_IPPE);
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  return -(R.t() * tvec);
}

double rms_px(const std::vector<cv::Point3d>& object, const std::vector<cv::Point2f>& image, const cv::Vec3d& rvec,
              const cv::Vec3d& tvec, const cv::Matx33d& K, const cv::Vec<double, 5>& D) {
  std::vector<cv::Point2d> projected;
  cv::projectPoints(object, rvec, tvec, K, D, projected);
  double sum = 0.0;
  for (size_t i = 0; i < image.size(); ++i) {
    const cv::Point2d d = projected[i] - cv::Point2d(image[i]);
    sum += d.dot(d);
  }
  return std::sqrt(sum / std::max<size_t>(image.size(), 1));
}

}  // namespace

std::vector<cv::Point3d> placement_corners_ned(const FloorPlacement& placement, const ChessboardSpec& board) {
  const double c = std::cos(placement.yaw_rad), s = std::sin(placement.yaw_rad);
  std::vector<cv::Point3d> points;
  for (int r = 0; r < board.inner_corners.height; ++r) {
    for (int col = 0; col < board.inner_corners.width; ++col) {
      const double x = col * board.square_m, y = r * board.square_m;
      points.emplace_back(placement.origin_ned[0] + c * x - s * y, placement.origin_ned[1] + s * x + c * y,
                          placement.origin_ned[2]);
    }
  }
  return points;
}

RoomCalibrationResult calibrate_room_camera(const std::vector<BoardView>& views, cv::Size image_size,
                                            const ChessboardSpec& board, const RoomCalibrationRequirements& req) {
  const int n = static_cast<int>(views.size());
  if (n < req.min_views) {
    throw CalibrationSetError("only " + std::to_string(n) + " board views; capture at least " +
                              std::to_string(req.min_views) +
                              " (held up in front of the camera, tilted in different directions, across the image)");
  }
  std::set<std::string> placement_ids;
  for (const BoardView& v : views) {
    if (v.placement) placement_ids.insert(v.placement->id);
  }
  if (static_cast<int>(placement_ids.size()) < req.min_placements) {
    throw CalibrationSetError("only " + std::to_string(placement_ids.size()) + " floor placements are seen; lay the "
                              "board flat at " + std::to_string(req.min_placements) +
                              " or more measured places spread over the flight area");
  }

  // Intrinsics: every view, in the board's own frame.
  std::vector<std::vector<cv::Point3f>> object(views.size(), board_points(board));
  std::vector<std::vector<cv::Point2f>> image;
  for (const BoardView& v : views) image.push_back(v.corners);
  cv::Mat K_mat, D_mat;
  std::vector<cv::Mat> rvecs, tvecs;
  RoomCalibrationResult result;
  result.views = n;
  // k3 fixed at zero: boards held in the flight area rarely reach the image corners, where a free k3
  // fits the views and extrapolates badly (pixels off at the edges of the field of view).
  result.intrinsic_rms_px =
      cv::calibrateCamera(object, image, image_size, K_mat, D_mat, rvecs, tvecs, cv::CALIB_FIX_K3);
  if (result.intrinsic_rms_px > req.max_rms_px) {
    char message[200];
    std::snprintf(message, sizeof message, "intrinsic reprojection RMS %.2f px above %.2f: some corners are wrong; "
                  "capture the whole board, sharp and still", result.intrinsic_rms_px, req.max_rms_px);
    throw CalibrationSetError(message);
  }
  RoomCamera& cam = result.camera;
  cam.image_size = image_size;
  cam.K = cv::Matx33d(K_mat);
  cam.D = cv::Vec<double, 5>(D_mat.reshape(1, 5));

  // The detector may give a view's corners from either end (the grid is symmetric under 180°). The
  // wrong order puts the camera at the mirror image of its place through the board's centre, which
  // differs per placement: keep, per view, the order whose camera centre agrees with the others.
  std::vector<const BoardView*> placed;
  std::vector<std::array<cv::Vec3d, 2>> centres;
  for (const BoardView& v : views) {
    if (!v.placement) continue;
    std::vector<cv::Point2f> reversed(v.corners.rbegin(), v.corners.rend());
    placed.push_back(&v);
    centres.push_back({centre_from_placement(v.corners, *v.placement, board, cam.K, cam.D),
                       centre_from_placement(reversed, *v.placement, board, cam.K, cam.D)});
  }
  std::vector<int> best_choice;
  double best_cost = std::numeric_limits<double>::infinity();
  for (int seed_choice = 0; seed_choice < 2; ++seed_choice) {
    const cv::Vec3d reference = centres[0][seed_choice];
    std::vector<int> choice;
    double cost = 0.0;
    for (const auto& pair : centres) {
      const double d0 = cv::norm(pair[0] - reference), d1 = cv::norm(pair[1] - reference);
      choice.push_back(d0 <= d1 ? 0 : 1);
      cost += std::min(d0, d1);
    }
    if (cost < best_cost) {
      best_cost = cost;
      best_choice = choice;
    }
  }

  // Room pose: one solvePnP over the corners of every placement, in NED.
  std::vector<cv::Point3d> ned_points;
  std::vector<cv::Point2f> pixels;
  for (size_t i = 0; i < placed.size(); ++i) {
    const std::vector<cv::Point3d> ned = placement_corners_ned(*placed[i]->placement, board);
    std::vector<cv::Point2f> corners = placed[i]->corners;
    if (best_choice[i] == 1) {
      std::reverse(corners.begin(), corners.end());
      ++result.reversed_placements;
    }
    ned_points.insert(ned_points.end(), ned.begin(), ned.end());
    pixels.insert(pixels.end(), corners.begin(), corners.end());
  }
  cv::Vec3d rvec, tvec;
  cv::solvePnP(ned_points, pixels, cam.K, cam.D, rvec, tvec, false, cv::SOLVEPNP_ITERATIVE);
  cv::solvePnPRefineLM(ned_points, pixels, cam.K, cam.D, rvec, tvec);
  cv::Rodrigues(rvec, cam.R_CI);
  cam.t_CI = tvec;
  result.placements = static_cast<int>(placement_ids.size());
  result.room_rms_px = rms_px(ned_points, pixels, rvec, tvec, cam.K, cam.D);
  for (size_t i = 0; i < placed.size(); ++i) {
    result.centre_spread_m = std::max(result.centre_spread_m, cv::norm(centres[i][best_choice[i]] - cam.centre_ned()));
  }
  if (result.room_rms_px > req.max_rms_px || result.centre_spread_m > req.max_centre_spread_m) {
    char message[320];
    std::snprintf(message, sizeof message,
                  "the floor placements disagree (room-pose RMS %.2f px, limit %.2f; camera centres from single "
                  "placements up to %.3f m apart, limit %.3f): check the placement coordinates and yaw against "
                  "the board's first corner and row direction",
                  result.room_rms_px, req.max_rms_px, result.centre_spread_m, req.max_centre_spread_m);
    throw CalibrationSetError(message);
  }
  return result;
}

}  // namespace quad::vision::ground
