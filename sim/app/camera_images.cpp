// quad_sim_camera: the simulator's rendered cameras on their own, without a flight.
//
//   quad_sim_camera --scenario FILE --chessboards DIR [--count 24]
//       stereo chessboard views (9x6 inner corners, 0.03 m squares) as DIR/leftNN.png, DIR/rightNN.png,
//       the set the simulator gives `vision_station calibrate --images DIR --board 9x6 --square 0.03`
//   quad_sim_camera --scenario FILE --floor DIR [--height 1.5] [--speed 0.5] [--count 4]
//       views of the floor from above the star, the vehicle level and moving north at SPEED m/s (motion
//       blur and interlacing show with the scenario's camera keys), as DIR/leftNN.png, DIR/rightNN.png
//
// The cameras are the scenario's camera keys and its model's cam_left / cam_right.
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <opencv2/imgcodecs.hpp>

#include "quad/sim/camera_model.h"
#include "quad/sim/scenario.h"
#include "quad/sim/station_calibration.h"
#include "quad/sim/stereo_camera.h"
#include "quad/sim/vehicle.h"

namespace {

int usage(const char* error) {
  if (error) std::fprintf(stderr, "quad_sim_camera: %s\n", error);
  std::fprintf(stderr,
               "usage: quad_sim_camera --scenario FILE --chessboards DIR [--count 24]\n"
               "       quad_sim_camera --scenario FILE --floor DIR [--height 1.5] [--speed 0.5] [--count 4]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace quad::sim;
  std::string scenario_path, chessboards, floor;
  double height = 1.5, speed = 0.5;
  int count = -1;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) return usage((a + " needs a value").c_str());
    const std::string v = argv[++i];
    if (a == "--scenario") scenario_path = v;
    else if (a == "--chessboards") chessboards = v;
    else if (a == "--floor") floor = v;
    else if (a == "--height") height = std::atof(v.c_str());
    else if (a == "--speed") speed = std::atof(v.c_str());
    else if (a == "--count") count = std::atoi(v.c_str());
    else return usage(("unknown argument " + a).c_str());
  }
  if (scenario_path.empty() || chessboards.empty() == floor.empty()) return usage("need --scenario and one of --chessboards, --floor");
  try {
    const Scenario s = load_scenario(scenario_path);
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
