// quad_sim_camera: the simulator's rendered cameras on their own, without a flight.
//
//   quad_sim_camera --scenario FILE --chessboards DIR [--count 24]
//       stereo chessboard views (9x6 inner corners, 0.03 m squares) as DIR/leftNN.png, DIR/rightNN.png,
//       the set the simulator gives `vision_station calibrate --images DIR --board 9x6 --square 0.03`
//   quad_sim_camera --scenario FILE --floor DIR [--height 1.5] [--speed 0.5] [--count 4]
//       views of the floor from above the star, the vehicle level and moving north at SPEED m/s (motion
//       blur and interlacing show with the scenario's camera keys), as DIR/leftNN.png, DIR/rightNN.png
//   quad_sim_camera --scenario FILE --room-boards DIR
//       the room cameras' (ground_cameras keys) calibration set: boards held and laid at floor placements,
//       DIR/views.csv, DIR/placements.csv and DIR/cameraK_NN.png, for `vision_station calibrate-room --images DIR`
//   quad_sim_camera --scenario FILE --room-frames DIR [--height 1.0] [--speed 0.5] [--count 4]
//       frame sets of the room cameras seeing the vehicle level at HEIGHT over the scenario's start, moving
//       north at SPEED m/s: DIR/frames.csv, DIR/vehicles.yaml and the images, for `vision_station track --frames`
//
// The onboard cameras are the scenario's camera keys and its model's cam_left / cam_right.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "quad/sim/camera_model.h"
#include "quad/sim/ground_camera_calibration.h"
#include "quad/sim/ground_camera_loop.h"
#include "quad/sim/scenario.h"
#include "quad/sim/station_calibration.h"
#include "quad/sim/stereo_camera.h"
#include "quad/sim/vehicle.h"

namespace {

int usage(const char* error) {
  if (error) std::fprintf(stderr, "quad_sim_camera: %s\n", error);
  std::fprintf(stderr,
               "usage: quad_sim_camera --scenario FILE --chessboards DIR [--count 24]\n"
               "       quad_sim_camera --scenario FILE --floor DIR [--height 1.5] [--speed 0.5] [--count 4]\n"
               "       quad_sim_camera --scenario FILE --room-boards DIR\n"
               "       quad_sim_camera --scenario FILE --room-frames DIR [--height 1.0] [--speed 0.5] [--count 4]\n");
  return 2;
}

// The room cameras' calibration set, or frame sets of the vehicle moving north at `height`.
int room_images(const quad::sim::Scenario& s, const std::string& boards, const std::string& frames, double height, double speed,
                int count) {
  using namespace quad::sim;
  const GroundCameraParams& p = s.ground_cameras;
  GroundCameraRenderer renderer(p, ground_cameras_from(p), Rng(s.seed, "ground_cameras"));
  if (!boards.empty()) {
    ChessboardTarget board;
    board.cols = 8;
    board.rows = 6;
    board.square_m = 0.10;
    const auto placements = floor_placements(renderer.cameras(), board, p.centre_ne, 6);
    const std::vector<int> views = write_room_views(renderer, board, placements, 12, Rng(s.seed, "room_board_poses"), boards);
    std::printf("room boards (8x6 inner corners, 0.10 m squares, %zu floor placements): %d and %d views of cameras 0 and 1 "
                "in %s\n", placements.size(), views.at(0), views.at(1), boards.c_str());
    return 0;
  }
  std::filesystem::create_directories(frames);
  MarkedVehicle v;
  v.markers_frd = p.markers_frd;
  v.marker_radius_m = p.marker_radius_m;
  const Eigen::Vector3d start(s.initial_north_east_m.x(), s.initial_north_east_m.y(), -height);
  v.p_ned = start;
  write_ground_vehicles_file(frames + "/vehicles.yaml", {v});
  std::FILE* list = std::fopen((frames + "/frames.csv").c_str(), "w");
  if (!list) throw std::runtime_error(frames + "/frames.csv: cannot write");
  std::fprintf(list, "time_us");
  for (size_t k = 0; k < renderer.cameras().size(); ++k) std::fprintf(list, ",camera_%zu", k);
  std::fprintf(list, "\n");
  cv::Mat image;
  for (int n = 0; n < (count > 0 ? count : 4); ++n) {
    const double t = n / p.rate_hz;
    v.p_ned = start + Eigen::Vector3d(speed * t, 0.0, 0.0);
    std::fprintf(list, "%lld", static_cast<long long>(std::llround(t * 1e6)));
    for (size_t k = 0; k < renderer.cameras().size(); ++k) {
      renderer.render(k, {v}, t, image);
      char name[48];
      std::snprintf(name, sizeof name, "f%03d_camera%zu.png", n, k);
      if (!cv::imwrite(frames + "/" + name, image)) throw std::runtime_error(frames + ": cannot write the images");
      std::fprintf(list, ",%s", name);
    }
    std::fprintf(list, "\n");
  }
  std::fclose(list);
  std::printf("room camera frame sets in %s\n", frames.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace quad::sim;
  std::string scenario_path, chessboards, floor, room_boards, room_frames;
  double height = -1.0, speed = 0.5;
  int count = -1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage((a + " needs a value").c_str());
    const std::string v = argv[++i];
    if (a == "--scenario") scenario_path = v;
    else if (a == "--chessboards") chessboards = v;
    else if (a == "--floor") floor = v;
    else if (a == "--room-boards") room_boards = v;
    else if (a == "--room-frames") room_frames = v;
    else if (a == "--height") height = std::atof(v.c_str());
    else if (a == "--speed") speed = std::atof(v.c_str());
    else if (a == "--count") count = std::atoi(v.c_str());
    else return usage(("unknown argument " + a).c_str());
  }
  const int outputs = !chessboards.empty() + !floor.empty() + !room_boards.empty() + !room_frames.empty();
  if (scenario_path.empty() || outputs != 1)
    return usage("need --scenario and one of --chessboards, --floor, --room-boards, --room-frames");
  try {
    const Scenario s = load_scenario(scenario_path);
    if (!room_boards.empty() || !room_frames.empty()) return room_images(s, room_boards, room_frames, height < 0 ? 1.0 : height, speed, count);
    if (height < 0) height = 1.5;
    VehicleParams vp;
    vp.model_path = s.model_path;
    Vehicle vehicle(vp);
    const SimStereoRig rig = stereo_rig_from_model(vehicle.model(), s.camera, s.model_path);
    if (!chessboards.empty()) {
      const ChessboardTarget board;
      StereoCameraRenderer renderer(s.camera, rig, {}, Rng(s.seed, "chessboard_noise"));
      const auto poses = chessboard_poses(rig, board, count > 0 ? count : 24, Rng(s.seed, "chessboard_poses"));
      write_chessboard_views(renderer, board, poses, chessboards);
      std::printf("%zu chessboard pairs (%dx%d inner corners, %.3f m squares) in %s\n", poses.size(), board.cols,
                  board.rows, board.square_m, chessboards.c_str());
      return 0;
    }
    std::filesystem::create_directories(floor);
    StereoCameraRenderer renderer(s.camera, rig, make_floor_scene(s.camera, Rng(s.seed, "floor_scene")), Rng(s.seed, "camera"));
    const Eigen::Quaterniond level = Eigen::Quaterniond::Identity();
    cv::Mat left, right;
    for (int k = 0; k < (count > 0 ? count : 4); ++k) {
      const double t = k / 30.0;
      renderer.render([&](double when) { return VehiclePose{Eigen::Vector3d(speed * when, 0.0, -height), level}; }, t, false,
                      left, right);
      char name[32];
      std::snprintf(name, sizeof name, "%02d.png", k + 1);
      cv::imwrite(floor + "/left" + name, left);
      cv::imwrite(floor + "/right" + name, right);
    }
    std::printf("floor views in %s\n", floor.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "quad_sim_camera: %s\n", e.what());
    return 1;
  }
}
