// How the station learns the room cameras: as a user would, from chessboard images. The simulator
// renders a printed board (8 × 6 inner corners, 0.10 m squares) held at varied poses in front of each
// camera and lying flat at measured floor placements (through its own camera model,
// quad/sim/ground_camera.h), runs `vision_station calibrate-room` on those images and hands the station
// the room file that command wrote. The station is never given the cameras' truth. The file is cached
// under a key of everything that shapes the images and of the calibrating executable.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "quad/sim/ground_camera.h"
#include "quad/sim/station_calibration.h"

namespace quad::sim {

// The board lying flat: inner corner (col c, row r) at origin + Rz(yaw) · (c · square, r · square, 0) NED
// (the placement convention of calibrate-room's placements.csv).
struct FloorBoardPlacement {
  std::string id;
  Eigen::Vector3d origin_ned = Eigen::Vector3d::Zero();
  double yaw_deg = 0.0;
};

// Placements around the flight area's centre where the whole card lies in at least one camera's view,
// at most `count` of them, preferring those two cameras see.
std::vector<FloorBoardPlacement> floor_placements(const std::vector<GroundCamera>& cameras, const ChessboardTarget& board,
                                                  const Eigen::Vector2d& centre_ne, int count);

// Renders DIR/views.csv, DIR/placements.csv and DIR/cameraK_NN.png: `held` views per camera at poses
// drawn by `rng`, and every placement each camera sees whole. Returns the number of views per camera.
std::vector<int> write_room_views(GroundCameraRenderer& renderer, const ChessboardTarget& board,
                                  const std::vector<FloorBoardPlacement>& placements, int held, Rng rng,
                                  const std::string& dir);

// The station's room file for these cameras: CACHE_DIR/room_calib-KEY.yaml, made on a cache miss by
// rendering the views and running `calibrate_room_argv --images DIR --board 8x6 --square 0.1 --out FILE`
// (its output in CACHE_DIR/room_calib-KEY.log). Throws CalibrationError when the command fails.
std::string room_calibration_file(const GroundCameraParams& params, const std::vector<std::string>& calibrate_room_argv,
                                  const std::string& cache_dir, const std::function<void(const std::string&)>& progress);

// A station command `X... run` with its last word replaced by `subcommand` (calibrate-room, track).
// Throws CalibrationError when the station command does not end in `run`.
std::vector<std::string> station_subcommand(const std::vector<std::string>& station_argv, const std::string& subcommand);

}  // namespace quad::sim
