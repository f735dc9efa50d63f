// Independent scenes for the ground-camera mode of the vision station: fixed room cameras (seed 003
// table 6.1 by default), chessboard views for the room calibration, and frame sets of vehicles wearing
// red, green, blue and yellow balls, moving, crossing, under varying light and noise. Projection through
// cv::projectPoints with this file's own camera poses and lens; marker drawing of its own. Shares no code
// with vision_station/ (only the file formats its commands read).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace ground_eval {

struct SceneCamera {
  cv::Size size;
  cv::Matx33d K;
  std::vector<double> distortion;  // k1, k2, p1, p2, k3
  cv::Vec3d rvec, tvec;            // NED -> camera (OpenCV axes)
  cv::Vec3d centre_ned;
};

struct RoomSpec {
  int cameras = 2;
  cv::Size size{1024, 768};
  double hfov_deg = 56.1;        // seed 003 table 6.1
  double height_m = 1.40;        // above the floor (NED down = -height)
  double distance_m = 2.20;      // horizontal distance from the flight area's centre
  double aim_height_m = 0.40;    // the optical axis passes over the centre at this height
  double first_azimuth_deg = 180.0;  // camera 0 south of the centre looking north, the next 90° further
};

std::vector<SceneCamera> make_room_cameras(const RoomSpec& spec);

struct BoardSpec {
  cv::Size inner{8, 6};
  double square_m = 0.10;
};

struct Placement {
  std::string id;
  cv::Vec3d origin_ned;  // inner corner (0, 0)
  double yaw_deg = 0.0;  // corner rows (along the 8 corners) point north at 0
};

// Writes DIR/views.csv, DIR/placements.csv and the PNG images for calibrate-room; returns the number of
// views written per camera.
std::vector<int> write_calibration_set(const std::string& dir, const std::vector<SceneCamera>& cameras,
                                       const BoardSpec& board, int free_views_per_camera, uint64_t seed);

// Marker layout in body FRD (red, green, blue, yellow) and the ball radius.
struct VehicleModel {
  std::array<cv::Vec3d, 4> markers{cv::Vec3d(0.22, 0.0, -0.02), cv::Vec3d(0.0, 0.22, -0.02),
                                   cv::Vec3d(-0.22, 0.0, -0.02), cv::Vec3d(0.0, -0.22, -0.07)};
  double ball_radius_m = 0.015;
};

struct VehicleState {
  int id = 0;
  cv::Vec3d ned;
  cv::Matx33d R_IB;  // body FRD -> NED
};

struct MarkerTruth {
  cv::Point2d pixel;      // centre of the ball's projection
  double visible = 0.0;   // fraction of the drawn disc not hidden by nearer objects
  bool in_image = false;
};

struct FrameTruth {
  int64_t time_us = 0;
  std::vector<VehicleState> vehicles;
  // markers[vehicle][camera][colour]
  std::vector<std::vector<std::array<MarkerTruth, 4>>> markers;
};

enum class Scenario { kSingle, kPair, kCrossing, kRetreat, kFour };
const char* scenario_name(Scenario s);

struct SceneOptions {
  Scenario scenario = Scenario::kSingle;
  int frames = 60;
  double rate_hz = 30.0;        // seed 003 table 6.1
  double noise_grey = 3.0;      // sensor noise, grey levels (1 sigma)
  double min_gain = 0.55, max_gain = 1.25;  // illumination over the sequence
  uint64_t seed = 1;
};

// Vehicle states of a scenario at time t (seconds from the first frame).
std::vector<VehicleState> scenario_states(Scenario scenario, double t, const std::vector<SceneCamera>& cameras);

// Renders one frame set (one BGR image per camera) and its truth.
std::vector<cv::Mat> render_frame_set(const std::vector<SceneCamera>& cameras, const VehicleModel& model,
                                      const std::vector<VehicleState>& vehicles, double gain, cv::RNG& rng,
                                      std::vector<std::vector<std::array<MarkerTruth, 4>>>& truth);

// Writes DIR/frames.csv, DIR/vehicles.yaml (marker layout and start poses), DIR/truth.csv and
// DIR/markers.csv, and the images; returns the truth in memory as well.
std::vector<FrameTruth> write_scene_set(const std::string& dir, const std::vector<SceneCamera>& cameras,
                                        const VehicleModel& model, const SceneOptions& options);

cv::Vec4d quaternion_of(const cv::Matx33d& R);  // Hamilton, scalar first, w >= 0

}  // namespace ground_eval
