#include "quad/sim/station_calibration.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <thread>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "quad/sim/firmware_process.h"

namespace quad::sim {
namespace fs = std::filesystem;

namespace {

constexpr int kViews = 24;
constexpr double kCardGrey = 215.0, kInkGrey = 30.0, kWallGrey = 120.0;
// Bumped whenever the chessboard images change for the same camera keys (poses, card, drawing).
constexpr const char* kChessboardVersion = "chessboard-2";

Eigen::Matrix3d rotation(const Eigen::Vector3d& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

// All of the card inside the image with a margin, on the lens' monotonic part.
bool card_in_view(const LensParams& lens, int width, int height, const CameraPose& pose, const ChessboardTarget& board) {
  const double valid = lens_fold_radius(lens);
  const double s = board.square_m;
  const int steps = 8;
  for (int i = 0; i <= steps; ++i) {
    for (int j = 0; j <= steps; ++j) {
      if (i != 0 && i != steps && j != 0 && j != steps) continue;  // the card's border
      const Eigen::Vector3d q(-2.0 * s + (board.cols + 3.0) * s * i / steps, -2.0 * s + (board.rows + 3.0) * s * j / steps, 0.0);
      const Eigen::Vector3d p = pose.R * q + pose.t;
      if (p.z() <= 0.05 || std::hypot(p.x() / p.z(), p.y() / p.z()) > 0.85 * valid) return false;
      const auto uv = project_lens(lens, valid, p);
      if (!uv || uv->x() < 12 || uv->y() < 12 || uv->x() > width - 13 || uv->y() > height - 13) return false;
    }
  }
  return true;
}

std::string key_text(const SimStereoRig& rig, const CameraParams& p, const ChessboardTarget& board) {
  std::ostringstream s;
  s.precision(17);
  s << kChessboardVersion << ' ' << rig.width << ' ' << rig.height;
  for (const LensParams* l : {&rig.left, &rig.right}) s << ' ' << l->fx << ' ' << l->fy << ' ' << l->cx << ' ' << l->cy << ' ' << l->k1 << ' ' << l->k2 << ' ' << l->p1 << ' ' << l->p2 << ' ' << l->k3;
  const Eigen::Matrix3d R = rig.R_right_left();
  const Eigen::Vector3d T = rig.T_right_left();
  for (int i = 0; i < 9; ++i) s << ' ' << R(i / 3, i % 3);
  s << ' ' << T.x() << ' ' << T.y() << ' ' << T.z();
  s << ' ' << p.noise_grey << ' ' << p.vignetting << ' ' << p.jpeg_quality << ' ' << board.cols << ' ' << board.rows << ' ' << board.square_m;
  return s.str();
}

std::string fnv1a_hex(const std::string& text) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  char out[17];
  std::snprintf(out, sizeof out, "%016llx", static_cast<unsigned long long>(h));
  return out;
}

}  // namespace

std::string calibration_cache_key(const std::string& images_text, const std::string& tool_path) {
  // The calibrating executable is part of the key: a rebuilt station calibrates again.
  std::string tool;
  std::error_code error;
  const auto tool_time = fs::last_write_time(tool_path, error);
  if (!error) tool = tool_path + " " + std::to_string(tool_time.time_since_epoch().count()) + " " +
                     std::to_string(fs::file_size(tool_path, error));
  return fnv1a_hex(images_text + " " + tool);
}

void run_calibration_command(const std::vector<std::string>& argv, const std::string& log, const std::string& partial,
                             const std::string& file) {
  std::string status;
  try {
    FirmwareProcess calibrate(argv, log);
    while (calibrate.running()) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    status = calibrate.status();
  } catch (const std::runtime_error& e) {
    throw CalibrationError(std::string("vision station calibration: ") + e.what());
  }
  if (status != "exited with status 0" || !fs::exists(partial))
    throw CalibrationError("vision station calibration " + status + " (see " + log + ")");
  fs::rename(partial, file);  // atomic: a parallel run sees the whole file or none
}

std::vector<FloorShape> chessboard_shapes(const ChessboardTarget& board) {
  const double s = board.square_m;
  auto rect = [](double x0, double y0, double x1, double y1, double grey) {
    return FloorShape{{{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}, grey};
  };
  std::vector<FloorShape> shapes{rect(-2.0 * s, -2.0 * s, (board.cols + 1.0) * s, (board.rows + 1.0) * s, kCardGrey)};
  // (cols + 1) × (rows + 1) squares, the first one black, so the inner corners are the (col, row) grid.
  for (int r = 0; r <= board.rows; ++r)
    for (int c = 0; c <= board.cols; ++c)
      if ((r + c) % 2 == 0) shapes.push_back(rect((c - 1) * s, (r - 1) * s, c * s, r * s, kInkGrey));
  return shapes;
}

std::vector<CameraPose> chessboard_poses(const SimStereoRig& rig, const ChessboardTarget& board, int count, Rng rng) {
  const Eigen::Vector3d centre((board.cols - 1) * 0.5 * board.square_m, (board.rows - 1) * 0.5 * board.square_m, 0.0);
  const Eigen::Matrix3d R = rig.R_right_left();
  const Eigen::Vector3d T = rig.T_right_left();
  std::vector<CameraPose> poses;
  for (int attempt = 0; attempt < 20000 && static_cast<int>(poses.size()) < count; ++attempt) {
    // Aim at a cell of a 4 × 3 grid over the image in turn, so the corners cover the whole image.
    const int cell = static_cast<int>(poses.size()) % 12;
    const double a = -0.55 + 1.1 * ((cell % 4) + rng.uniform()) / 4.0;
    const double b = -0.40 + 0.8 * ((cell / 4) + rng.uniform()) / 3.0;
    const double distance = rng.uniform(0.45, 0.8);
    const double tilt = rng.uniform(10.0, 35.0) * M_PI / 180.0, tilt_dir = rng.uniform(0.0, 2.0 * M_PI);
    const double spin = rng.uniform(-0.35, 0.35);
    const Eigen::Matrix3d Rb = rotation(Eigen::Vector3d(std::cos(tilt_dir), std::sin(tilt_dir), 0.0), tilt) *
                               rotation(Eigen::Vector3d::UnitZ(), spin);
    const CameraPose left{Rb, distance * Eigen::Vector3d(a, b, 1.0) - Rb * centre};
    const CameraPose right{R * left.R, R * left.t + T};
    if (card_in_view(rig.left, rig.width, rig.height, left, board) && card_in_view(rig.right, rig.width, rig.height, right, board))
      poses.push_back(left);
  }
  return poses;
}

void write_chessboard_views(StereoCameraRenderer& renderer, const ChessboardTarget& board, const std::vector<CameraPose>& poses,
                            const std::string& dir) {
  fs::create_directories(dir);
  const std::vector<FloorShape> shapes = chessboard_shapes(board);
  cv::Mat left, right;
  for (size_t i = 0; i < poses.size(); ++i) {
    renderer.render_target(poses[i], shapes, kWallGrey, left, right);
    char name[32];
    std::snprintf(name, sizeof name, "%02zu.png", i + 1);
    if (!cv::imwrite(dir + "/left" + name, left) || !cv::imwrite(dir + "/right" + name, right))
      throw CalibrationError(dir + ": cannot write the chessboard images");
  }
}

std::vector<std::string> calibrate_command_for(const std::vector<std::string>& station_argv) {
  if (station_argv.empty() || station_argv.back() != "run")
    throw CalibrationError("the vision station command must end in 'run' so that the simulator can run its 'calibrate'");
  std::vector<std::string> argv = station_argv;
  argv.back() = "calibrate";
  return argv;
}

std::string station_calibration_file(const SimStereoRig& rig, const CameraParams& params, const std::vector<std::string>& calibrate_argv,
                                     const std::string& cache_dir, const std::function<void(const std::string&)>& progress) {
  const ChessboardTarget board;
  const std::string key = calibration_cache_key(key_text(rig, params, board), calibrate_argv.at(0));
  const std::string file = cache_dir + "/station_calib-" + key + ".yaml";
  if (fs::exists(file)) {
    progress("station calibration: " + file + " (cached)");
    return file;
  }
  fs::create_directories(cache_dir);
  const std::string work = cache_dir + "/chessboards-" + key + "-" + std::to_string(getpid());
  // The chessboard images carry the flight images' sensor noise, vignetting and compression; no
  // exposure wander, motion or interlacing (the board is held still).
  CameraParams still = params;
  still.exposure_variation = 0.0;
  still.exposure_s = 0.0;
  still.interlaced = false;
  still.floor_texture.clear();
  StereoCameraRenderer renderer(still, rig, {}, Rng(1, "chessboard_noise"));
  const std::vector<CameraPose> poses = chessboard_poses(rig, board, kViews, Rng(1, "chessboard_poses"));
  progress("station calibration: rendering " + std::to_string(poses.size()) + " chessboard pairs into " + work);
  write_chessboard_views(renderer, board, poses, work);
  const std::string partial = file + "." + std::to_string(getpid()) + ".partial.yaml";
  std::vector<std::string> argv = calibrate_argv;
  char square[32];
  std::snprintf(square, sizeof square, "%.6f", board.square_m);
  for (const std::string& a : {std::string("--images"), work, std::string("--board"),
                               std::to_string(board.cols) + "x" + std::to_string(board.rows), std::string("--square"),
                               std::string(square), std::string("--out"), partial})
    argv.push_back(a);
  const std::string log = cache_dir + "/station_calib-" + key + ".log";
  progress("station calibration: " + argv[0] + " calibrate (output in " + log + ")");
  run_calibration_command(argv, log, partial, file);
  fs::remove_all(work);
  return file;
}

void write_focal_error_calibration(const std::string& in, const std::string& out, double error) {
  cv::FileStorage src(in, cv::FileStorage::READ);
  if (!src.isOpened()) throw CalibrationError(in + ": cannot read the calibration");
  cv::Mat K1, D1, K2, D2, R, T;
  src["K1"] >> K1;
  src["D1"] >> D1;
  src["K2"] >> K2;
  src["D2"] >> D2;
  src["R"] >> R;
  src["T"] >> T;
  const int width = static_cast<int>(src["image_width"]), height = static_cast<int>(src["image_height"]);
  if (K1.empty() || K2.empty() || D1.empty() || D2.empty() || R.empty() || T.empty() || width <= 0 || height <= 0)
    throw CalibrationError(in + ": not a stereo calibration (K1 D1 K2 D2 R T image_width image_height)");
  for (cv::Mat* K : {&K1, &K2}) {
    K->at<double>(0, 0) *= 1.0 + error;
    K->at<double>(1, 1) *= 1.0 + error;
  }
  cv::Mat R1, R2, P1, P2, Q;
  const cv::Size size(width, height);
  cv::stereoRectify(K1, D1, K2, D2, size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, -1.0, size);
  cv::FileStorage dst(out, cv::FileStorage::WRITE);
  if (!dst.isOpened()) throw CalibrationError(out + ": cannot write the calibration");
  dst << "image_width" << width << "image_height" << height << "K1" << K1 << "D1" << D1 << "K2" << K2 << "D2" << D2
      << "R" << R << "T" << T << "R1" << R1 << "R2" << R2 << "P1" << P1 << "P2" << P2 << "Q" << Q;
}

void write_station_settings(const std::string& path, const CameraMountModel& left_mount,
                            const std::vector<std::pair<std::string, std::string>>& extra) {
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw CalibrationError(path + ": cannot write the station settings");
  cv::Mat R(3, 3, CV_64F), t(3, 1, CV_64F);
  for (int i = 0; i < 3; ++i) {
    t.at<double>(i) = left_mount.t_BC(i);
    for (int j = 0; j < 3; ++j) R.at<double>(i, j) = left_mount.R_BC(i, j);
  }
  fs << "camera_to_body_R" << R << "camera_to_body_t" << t;
  for (const auto& [name, value] : extra) {
    char* end = nullptr;
    const double number = std::strtod(value.c_str(), &end);
    const bool numeric = end != value.c_str() && *end == '\0';
    if (numeric && number == std::floor(number) && std::fabs(number) < 1e9) fs << name << static_cast<int>(number);
    else if (numeric) fs << name << number;
    else fs << name << value;
  }
}

}  // namespace quad::sim
