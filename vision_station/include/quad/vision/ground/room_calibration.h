// Calibration of fixed ground cameras to the room (seed 003 sec. 3.1): the intrinsics from several
// chessboard views (cv::calibrateCamera), the pose in the room's NED frame from the views of the board
// lying at known floor placements (one cv::solvePnP over the corners of all placements together).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "quad/vision/chessboard_calibration.h"
#include "quad/vision/ground/room_camera.h"

namespace quad::vision::ground {

// A board placement measured in the room: corner (col c, row r) lies at
// origin + Rz(yaw)·(c·square, r·square, 0) in NED (the board flat, its rows along north at yaw 0).
struct FloorPlacement {
  std::string id;
  cv::Vec3d origin_ned;
  double yaw_rad = 0.0;
};

// One chessboard view of one camera; a placement when the board lay at a known place.
struct BoardView {
  std::string label;  // file name, for messages
  std::vector<cv::Point2f> corners;
  std::optional<FloorPlacement> placement;
};

struct RoomCalibrationRequirements {
  int min_views = 8;                    // views for the intrinsics (placements included)
  int min_placements = 2;               // distinct floor placements for the room pose
  double max_rms_px = 1.0;              // intrinsic and room-pose reprojection RMS
  double max_centre_spread_m = 0.05;    // camera centres from single placements must agree this well
};

struct RoomCalibrationResult {
  RoomCamera camera;
  double intrinsic_rms_px = 0.0;   // calibrateCamera over all views
  double room_rms_px = 0.0;        // joint solvePnP over the placements' corners
  double centre_spread_m = 0.0;    // largest distance of a single placement's camera centre from the joint one
  int views = 0;
  int placements = 0;
  int reversed_placements = 0;     // placements whose corner order the detector gave from the far end
};

// Refuses (CalibrationSetError, saying what to capture) too few views or placements, a large RMS and
// placements that disagree (wrong coordinates in the placement list).
RoomCalibrationResult calibrate_room_camera(const std::vector<BoardView>& views, cv::Size image_size,
                                            const ChessboardSpec& board,
                                            const RoomCalibrationRequirements& requirements = {});

// Board corner positions in NED for a placement, in the detector's corner order.
std::vector<cv::Point3d> placement_corners_ned(const FloorPlacement& placement, const ChessboardSpec& board);

}  // namespace quad::vision::ground
