// How the vision station in the loop learns the simulator's cameras: as a user would, from chessboard
// views. The simulator renders a printed chessboard held at many poses in front of both cameras
// (through its own camera model, quad/sim/camera_model.h), runs `vision_station calibrate` on those
// images, and hands the station the calibration file that command wrote. The file is cached under a key
// of everything that shapes the chessboard images, so a flight recalibrates only when the cameras
// change (or the calibrating executable is rebuilt). The camera-to-body mount, which chessboards cannot give, goes to the station's settings file
// (camera_to_body_R, camera_to_body_t) as the value a builder would measure on the airframe.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "quad/sim/camera_model.h"
#include "quad/sim/rng.h"
#include "quad/sim/scenario.h"
#include "quad/sim/stereo_camera.h"

namespace quad::sim {

// A printed chessboard: inner corners (cols × rows), square side, on a white card one square wider
// on every side.
struct ChessboardTarget {
  int cols = 9, rows = 6;
  double square_m = 0.03;
};

// The card and its black squares in the board's plane (x along the columns, y along the rows, the
// first inner corner at the origin).
std::vector<FloorShape> chessboard_shapes(const ChessboardTarget& board);

// `count` board poses (board plane to left camera) 0.45 to 0.8 m away, tilted 10 to 35 degrees towards
// varied sides and spread over the image, each showing the whole card in both cameras.
std::vector<CameraPose> chessboard_poses(const SimStereoRig& rig, const ChessboardTarget& board, int count, Rng rng);

// Renders the views as DIR/leftNN.png and DIR/rightNN.png (the `vision_station calibrate --images DIR`
// layout).
void write_chessboard_views(StereoCameraRenderer& renderer, const ChessboardTarget& board,
                            const std::vector<CameraPose>& poses, const std::string& dir);

struct CalibrationError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The station's calibration for this rig: CACHE_DIR/station_calib-KEY.yaml (KEY: the cameras, the
// chessboard set and the calibrating executable's path, time and size), made on a cache miss by
// rendering the chessboard views and running `calibrate_argv --images DIR --board 9x6 --square S
// --out FILE` (its output in CACHE_DIR/station_calib-KEY.log). `progress` gets one line per step.
// Throws CalibrationError when the command fails.
std::string station_calibration_file(const SimStereoRig& rig, const CameraParams& params,
                                     const std::vector<std::string>& calibrate_argv, const std::string& cache_dir,
                                     const std::function<void(const std::string&)>& progress);

// The cache key of a calibration: a hash of the text describing its images and of the calibrating
// executable's path, time and size (a rebuilt station calibrates again).
std::string calibration_cache_key(const std::string& images_text, const std::string& tool_path);

// Runs a calibrating command (its output in `log`) that writes `partial`, then renames `partial` to
// `file` (atomically: a parallel run sees the whole file or none). Throws CalibrationError when the
// command fails or writes nothing.
void run_calibration_command(const std::vector<std::string>& argv, const std::string& log, const std::string& partial,
                             const std::string& file);

// The calibration command for a station command: `X... run` becomes `X... calibrate`. Throws
// CalibrationError when the station command does not end in `run`.
std::vector<std::string> calibrate_command_for(const std::vector<std::string>& station_argv);

// Copies a calibration file with both focal lengths scaled by (1 + error) and the rectification
// recomputed (cv::stereoRectify, zero disparity, default scaling): a mis-calibrated station.
void write_focal_error_calibration(const std::string& in, const std::string& out, double error);

// The station's settings file: the left camera's mount (camera_to_body_R, camera_to_body_t) and the
// scenario's extra station settings (numbers or words).
void write_station_settings(const std::string& path, const CameraMountModel& left_mount,
                            const std::vector<std::pair<std::string, std::string>>& extra);

}  // namespace quad::sim
