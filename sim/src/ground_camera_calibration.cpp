#include "quad/sim/ground_camera_calibration.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

namespace quad::sim {
namespace fs = std::filesystem;

namespace {

constexpr double kPi = 3.14159265358979323846;
// Bumped whenever the room-calibration images change for the same keys (poses, card, drawing).
constexpr const char* kRoomBoardVersion = "room-board-1";
constexpr int kHeldViews = 12, kPlacements = 6;

Eigen::Matrix3d rotation(const Eigen::Vector3d& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

// All of the card inside the image with a margin.
bool card_in_view(const GroundCamera& camera, const CameraPose& pose, const ChessboardTarget& board) {
  const double valid = lens_fold_radius(camera.lens);
  const double s = board.square_m;
  constexpr int kSteps = 8;
  for (int i = 0; i <= kSteps; ++i)
    for (int j = 0; j <= kSteps; ++j) {
      if (i != 0 && i != kSteps && j != 0 && j != kSteps) continue;  // the card's border
      const Eigen::Vector3d q(-2.0 * s + (board.cols + 3.0) * s * i / kSteps, -2.0 * s + (board.rows + 3.0) * s * j / kSteps, 0.0);
      const Eigen::Vector3d p = pose.R * q + pose.t;
      if (p.z() <= 0.05 || std::hypot(p.x() / p.z(), p.y() / p.z()) > 0.85 * valid) return false;
      const auto uv = project_lens(camera.lens, valid, p);
      if (!uv || uv->x() < 16 || uv->y() < 16 || uv->x() > camera.width - 17 || uv->y() > camera.height - 17) return false;
    }
  return true;
}

CameraPose placement_pose(const GroundCamera& camera, const FloorBoardPlacement& p) {
  // Board plane (x along the columns, y along the rows) to NED, then to the camera.
  const Eigen::Matrix3d R_IP = rotation(Eigen::Vector3d::UnitZ(), p.yaw_deg * kPi / 180.0);
  return CameraPose{camera.R_CI * R_IP, camera.R_CI * p.origin_ned + camera.t_CI};
}

std::string key_text(const GroundCameraParams& p, const std::vector<GroundCamera>& cameras, const ChessboardTarget& board) {
  std::ostringstream s;
  s.precision(17);
  s << kRoomBoardVersion << ' ' << p.image_width << ' ' << p.image_height;
  for (const GroundCamera& c : cameras) {
    const LensParams& l = c.lens;
    s << ' ' << l.fx << ' ' << l.fy << ' ' << l.cx << ' ' << l.cy << ' ' << l.k1 << ' ' << l.k2 << ' ' << l.p1 << ' ' << l.p2 << ' ' << l.k3;
    for (int i = 0; i < 9; ++i) s << ' ' << c.R_CI(i / 3, i % 3);
    s << ' ' << c.t_CI.x() << ' ' << c.t_CI.y() << ' ' << c.t_CI.z();
  }
  s << ' ' << p.noise_grey << ' ' << p.light_ramp << ' ' << p.white_balance << ' ' << board.cols << ' ' << board.rows << ' '
    << board.square_m;
  return s.str();
}

}  // namespace

std::vector<FloorBoardPlacement> floor_placements(const std::vector<GroundCamera>& cameras, const ChessboardTarget& board,
                                                  const Eigen::Vector2d& centre_ne, int count) {
  // Candidates on a 0.35 m grid around the centre, both yaws; those seen by the most cameras first,
  // then nearest the centre; two placements overlap at most partly (origins 0.5 m apart).
  struct Candidate {
    FloorBoardPlacement p;
    int seen;
    double distance;
  };
  std::vector<Candidate> candidates;
  const Eigen::Vector2d half(0.5 * (board.cols - 1) * board.square_m, 0.5 * (board.rows - 1) * board.square_m);
  for (int i = -5; i <= 5; ++i)
    for (int j = -5; j <= 5; ++j)
      for (double yaw : {0.0, 90.0}) {
        const Eigen::Vector2d board_centre = centre_ne + 0.35 * Eigen::Vector2d(i, j);
        const Eigen::Vector2d h = yaw == 0.0 ? half : Eigen::Vector2d(-half.y(), half.x());
        FloorBoardPlacement p;
        p.origin_ned = Eigen::Vector3d(board_centre.x() - h.x(), board_centre.y() - h.y(), 0.0);
        p.yaw_deg = yaw;
        int seen = 0;
        for (const GroundCamera& c : cameras) seen += card_in_view(c, placement_pose(c, p), board) ? 1 : 0;
        if (seen > 0) candidates.push_back({p, seen, (board_centre - centre_ne).norm()});
      }
  std::stable_sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return a.seen != b.seen ? a.seen > b.seen : a.distance < b.distance;
  });
  std::vector<FloorBoardPlacement> out;
  for (const Candidate& c : candidates) {
    if (static_cast<int>(out.size()) >= count) break;
    bool apart = true;
    for (const FloorBoardPlacement& q : out) apart = apart && (q.origin_ned - c.p.origin_ned).norm() > 0.5;
    if (!apart) continue;
    out.push_back(c.p);
    out.back().id = "P" + std::to_string(out.size());
  }
  return out;
}

std::vector<int> write_room_views(GroundCameraRenderer& renderer, const ChessboardTarget& board,
                                  const std::vector<FloorBoardPlacement>& placements, int held, Rng rng,
                                  const std::string& dir) {
  fs::create_directories(dir);
  const std::vector<FloorShape> shapes = chessboard_shapes(board);
  std::ofstream views(dir + "/views.csv"), places(dir + "/placements.csv");
  views << "camera,image,placement\n";
  places << "placement,north,east,down,yaw_deg\n";
  char line[160];
  for (const FloorBoardPlacement& p : placements) {
    std::snprintf(line, sizeof line, "%s,%.6f,%.6f,%.6f,%.3f\n", p.id.c_str(), p.origin_ned.x(), p.origin_ned.y(),
                  p.origin_ned.z(), p.yaw_deg);
    places << line;
  }
  const Eigen::Vector3d centre((board.cols - 1) * 0.5 * board.square_m, (board.rows - 1) * 0.5 * board.square_m, 0.0);
  std::vector<int> counts;
  cv::Mat image;
  for (size_t k = 0; k < renderer.cameras().size(); ++k) {
    const GroundCamera& camera = renderer.cameras()[k];
    int n = 0;
    auto write = [&](const CameraPose& pose, const std::string& placement) {
      renderer.render_target(k, pose, shapes, image);
      char name[48];
      std::snprintf(name, sizeof name, "camera%zu_%02d.png", k, ++n);
      if (!cv::imwrite(dir + "/" + name, image)) throw CalibrationError(dir + ": cannot write the chessboard images");
      views << k << "," << name << "," << placement << "\n";
    };
    // Held in front of the camera: 1.4 to 2.6 m away, tilted 20 to 45 degrees, spread over a 4 × 3 grid.
    for (int attempt = 0, got = 0; attempt < 20000 && got < held; ++attempt) {
      const int cell = got % 12;
      const double a = -0.45 + 0.9 * ((cell % 4) + rng.uniform()) / 4.0;
      const double b = -0.32 + 0.64 * ((cell / 4) + rng.uniform()) / 3.0;
      const double distance = rng.uniform(1.4, 2.6);
      const double tilt = rng.uniform(20.0, 45.0) * kPi / 180.0, tilt_dir = rng.uniform(0.0, 2.0 * kPi);
      const Eigen::Matrix3d R = rotation(Eigen::Vector3d(std::cos(tilt_dir), std::sin(tilt_dir), 0.0), tilt) *
                                rotation(Eigen::Vector3d::UnitZ(), rng.uniform(-0.35, 0.35));
      const CameraPose pose{R, distance * Eigen::Vector3d(a, b, 1.0) - R * centre};
      if (!card_in_view(camera, pose, board)) continue;
      write(pose, "");
      ++got;
    }
    for (const FloorBoardPlacement& p : placements) {
      const CameraPose pose = placement_pose(camera, p);
      if (card_in_view(camera, pose, board)) write(pose, p.id);
    }
    counts.push_back(n);
  }
  if (!views || !places) throw CalibrationError(dir + ": cannot write views.csv or placements.csv");
  return counts;
}

std::string room_calibration_file(const GroundCameraParams& params, const std::vector<std::string>& calibrate_room_argv,
                                  const std::string& cache_dir, const std::function<void(const std::string&)>& progress) {
  ChessboardTarget board;
  board.cols = 8;
  board.rows = 6;
  board.square_m = 0.10;
  const std::vector<GroundCamera> cameras = ground_cameras_from(params);
  const std::string key = calibration_cache_key(key_text(params, cameras, board), calibrate_room_argv.at(0));
  const std::string file = cache_dir + "/room_calib-" + key + ".yaml";
  if (fs::exists(file)) {
    progress("room calibration: " + file + " (cached)");
    return file;
  }
  fs::create_directories(cache_dir);
  const std::string work = cache_dir + "/room_boards-" + key + "-" + std::to_string(getpid());
  // The board images carry the flight images' lenses, ramp, colour cast and noise at the nominal light.
  GroundCameraRenderer renderer(params, cameras, Rng(1, "room_board_noise"));
  const std::vector<FloorBoardPlacement> placements = floor_placements(cameras, board, params.centre_ne, kPlacements);
  const std::vector<int> counts = write_room_views(renderer, board, placements, kHeldViews, Rng(1, "room_board_poses"), work);
  std::string summary;
  for (size_t k = 0; k < counts.size(); ++k) summary += (k ? ", " : "") + std::to_string(counts[k]);
  progress("room calibration: rendered " + summary + " board views per camera (" + std::to_string(placements.size()) +
           " floor placements) into " + work);
  const std::string partial = file + "." + std::to_string(getpid()) + ".partial.yaml";
  std::vector<std::string> argv = calibrate_room_argv;
  for (const std::string& a : {std::string("--images"), work, std::string("--board"), std::string("8x6"), std::string("--square"),
                               std::string("0.1"), std::string("--out"), partial})
    argv.push_back(a);
  const std::string log = cache_dir + "/room_calib-" + key + ".log";
  progress("room calibration: " + argv[0] + " calibrate-room (output in " + log + ")");
  run_calibration_command(argv, log, partial, file);
  fs::remove_all(work);
  return file;
}

std::vector<std::string> station_subcommand(const std::vector<std::string>& station_argv, const std::string& subcommand) {
  if (station_argv.empty() || station_argv.back() != "run")
    throw CalibrationError("the vision station command must end in 'run' so that the simulator can run its '" + subcommand + "'");
  std::vector<std::string> argv = station_argv;
  argv.back() = subcommand;
  return argv;
}

}  // namespace quad::sim
