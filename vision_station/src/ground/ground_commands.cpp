#include "quad/vision/ground/ground_commands.h"

#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <set>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/ground/csv_table.h"
#include "quad/vision/ground/ground_tracker.h"
#include "quad/vision/ground/room_calibration.h"

namespace quad::vision::ground {
namespace {

const std::string& require(const std::map<std::string, std::string>& options, const std::string& key) {
  const auto it = options.find(key);
  if (it == options.end()) throw CommandUsageError("missing " + key);
  return it->second;
}

cv::Mat read_colour(const std::string& path) {
  cv::Mat image = cv::imread(path, cv::IMREAD_COLOR);
  if (image.empty()) throw std::runtime_error(path + ": cannot read the image");
  return image;
}

ChessboardSpec board_from(const std::map<std::string, std::string>& options) {
  ChessboardSpec board;
  board.inner_corners = cv::Size(8, 6);
  board.square_m = 0.10;
  if (options.count("--board")) {
    int w = 0, h = 0;
    char x = 0;
    if (std::sscanf(options.at("--board").c_str(), "%d%c%d", &w, &x, &h) != 3 || x != 'x' || w < 2 || h < 2) {
      throw CommandUsageError("--board '" + options.at("--board") + "': expected inner corners as COLSxROWS, e.g. 8x6");
    }
    board.inner_corners = cv::Size(w, h);
  }
  if (options.count("--square")) {
    try {
      board.square_m = std::stod(options.at("--square"));
    } catch (const std::exception&) {
      throw CommandUsageError("--square '" + options.at("--square") + "' is not a number");
    }
    if (!(board.square_m > 0.0)) throw CommandUsageError("--square must be positive");
  }
  return board;
}

std::map<std::string, FloorPlacement> read_placements(const std::string& path) {
  const CsvTable table = read_csv(path, {"placement", "north", "east", "down", "yaw_deg"});
  std::map<std::string, FloorPlacement> placements;
  for (const CsvRow& row : table.rows) {
    FloorPlacement p;
    p.id = table.at(row, "placement");
    p.origin_ned = cv::Vec3d(table.number(row, "north"), table.number(row, "east"), table.number(row, "down"));
    p.yaw_rad = table.number(row, "yaw_deg") * CV_PI / 180.0;
    if (!placements.emplace(p.id, p).second) {
      throw std::runtime_error(path + ":" + std::to_string(row.line) + ": placement '" + p.id + "' listed twice");
    }
  }
  return placements;
}

std::string vec_json(const double* v, int n) {
  std::string s = "[";
  char buffer[32];
  for (int i = 0; i < n; ++i) {
    std::snprintf(buffer, sizeof buffer, "%s%.9g", i ? "," : "", v[i]);
    s += buffer;
  }
  return s + "]";
}

std::string fix_json(const VehicleFix& fix, const FrameSetResult& frame) {
  std::string s = "{\"id\":" + std::to_string(fix.id) + ",\"time_us\":" + std::to_string(fix.time_us) +
                  ",\"found\":" + (fix.pose ? "true" : "false");
  if (fix.pose) {
    const RigidPose& p = *fix.pose;
    s += ",\"ned\":" + vec_json(p.position_ned.val, 3) + ",\"q_IB\":" + vec_json(p.q_IB.val, 4) +
         ",\"position_cov\":" + vec_json(p.position_covariance.val, 9) +
         ",\"attitude_cov\":" + vec_json(p.attitude_covariance.val, 9);
    char fit[48];
    std::snprintf(fit, sizeof fit, ",\"fit_rms_m\":%.6f", p.fit_rms_m);
    s += fit;
  }
  s += ",\"markers\":" + std::to_string(fix.markers) + ",\"pixels\":{";
  for (int k = 0; k < kMarkerColours; ++k) {
    s += std::string(k ? "," : "") + "\"" + colour_name(static_cast<MarkerColour>(k)) + "\":[";
    for (size_t c = 0; c < fix.pixels[k].size(); ++c) {
      const auto& px = fix.pixels[k][c];
      const double uv[2] = {px ? px->x : 0.0, px ? px->y : 0.0};
      s += (c ? "," : "") + (px ? vec_json(uv, 2) : std::string("null"));
    }
    s += "]";
  }
  char tail[160];
  std::snprintf(tail, sizeof tail, "},\"ambiguous_gates\":%d,\"epipolar_resolutions\":%d,\"ms\":%.3f,\"cpu_ms\":%.3f}",
                fix.ambiguous_gates, fix.epipolar_resolutions, frame.processing_ms, frame.cpu_ms);
  return s + tail;
}

}  // namespace

int calibrate_room_command(const std::map<std::string, std::string>& options) {
  const std::string dir = require(options, "--images");
  const std::string out = require(options, "--out");
  const ChessboardSpec board = board_from(options);
  const std::map<std::string, FloorPlacement> placements = read_placements(dir + "/placements.csv");
  const CsvTable views = read_csv(dir + "/views.csv", {"camera", "image", "placement"});
  std::map<int, std::vector<BoardView>> per_camera;
  std::map<int, cv::Size> sizes;
  for (const CsvRow& row : views.rows) {
    const double camera_number = views.number(row, "camera");
    const int camera = static_cast<int>(camera_number);
    if (camera != camera_number || camera < 0) {
      throw std::runtime_error(views.path + ":" + std::to_string(row.line) + ": camera must be 0, 1, ...");
    }
    const std::string file = views.file(row, "image");
    const cv::Mat image = read_colour(file);
    if (!sizes.count(camera)) sizes[camera] = image.size();
    if (image.size() != sizes[camera]) throw std::runtime_error(file + ": image size differs from camera's first view");
    BoardView view;
    view.label = file;
    const std::string& placement = views.at(row, "placement");
    if (!placement.empty()) {
      const auto it = placements.find(placement);
      if (it == placements.end()) {
        throw std::runtime_error(views.path + ":" + std::to_string(row.line) + ": placement '" + placement +
                                 "' is not in placements.csv");
      }
      view.placement = it->second;
    }
    cv::Mat grey;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    const auto corners = find_chessboard(grey, board);
    if (!corners) {
      std::cerr << "calibrate-room: board not found in " << file << "\n";
      continue;
    }
    view.corners = *corners;
    per_camera[camera].push_back(view);
  }
  if (per_camera.size() < 2) throw std::runtime_error(views.path + ": views of fewer than two cameras");
  RoomRig rig;
  for (const auto& [camera, camera_views] : per_camera) {
    if (camera != static_cast<int>(rig.cameras.size())) {
      throw std::runtime_error(views.path + ": no usable view of camera " + std::to_string(rig.cameras.size()));
    }
    RoomCalibrationResult result;
    try {
      result = calibrate_room_camera(camera_views, sizes[camera], board);
    } catch (const CalibrationSetError& e) {
      throw std::runtime_error("camera " + std::to_string(camera) + ": " + e.what());
    }
    const cv::Vec3d centre = result.camera.centre_ned();
    std::printf("camera %d: %d views, %d placements (%d read in reverse corner order); intrinsic RMS %.3f px, "
                "room RMS %.3f px; fx %.1f fy %.1f px; centre NED (%.3f, %.3f, %.3f) m, spread %.4f m\n",
                camera, result.views, result.placements, result.reversed_placements, result.intrinsic_rms_px,
                result.room_rms_px, result.camera.K(0, 0), result.camera.K(1, 1), centre[0], centre[1], centre[2],
                result.centre_spread_m);
    rig.cameras.push_back(result.camera);
  }
  save_room_rig(rig, out);
  std::printf("written to %s\n", out.c_str());
  return 0;
}

int track_command(const std::map<std::string, std::string>& options) {
  const RoomRig rig = load_room_rig(require(options, "--room"));
  const TrackerConfig config = load_tracker_config(require(options, "--vehicles"));
  GroundTrackerSettings settings;
  settings.use_epipolar = !options.count("--no-epipolar");
  settings.use_roi = !options.count("--no-roi");
  const CsvTable frames = read_csv(require(options, "--frames"), {"time_us"});
  std::vector<std::string> columns;
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    columns.push_back("camera_" + std::to_string(c));
    if (std::find(frames.columns.begin(), frames.columns.end(), columns.back()) == frames.columns.end()) {
      throw std::runtime_error(frames.path + ": header lacks the column '" + columns.back() + "'");
    }
  }
  std::unique_ptr<std::ofstream> file;
  if (options.count("--out")) {
    file = std::make_unique<std::ofstream>(options.at("--out"));
    if (!*file) throw std::runtime_error(options.at("--out") + ": cannot write");
  }
  std::ostream& out = file ? *file : std::cout;
  GroundTracker tracker(rig, config, settings);
  int sets = 0;
  double total_ms = 0.0, total_cpu_ms = 0.0;
  for (const CsvRow& row : frames.rows) {
    std::vector<cv::Mat> images;
    for (const std::string& column : columns) images.push_back(read_colour(frames.file(row, column)));
    const FrameSetResult result = tracker.process(images, static_cast<int64_t>(frames.number(row, "time_us")));
    for (const VehicleFix& fix : result.vehicles) out << fix_json(fix, result) << "\n";
    ++sets;
    total_ms += result.processing_ms;
    total_cpu_ms += result.cpu_ms;
  }
  const AssociationStats& t = tracker.totals();
  std::fprintf(stderr,
               "track: %d frame sets, %.2f ms (CPU %.2f ms) per set; detections %d, assigned %d, ambiguous gates %d, epipolar "
               "resolutions %d (nearest neighbour alone would differ in %d), searches roi %d full %d\n",
               sets, sets ? total_ms / sets : 0.0, sets ? total_cpu_ms / sets : 0.0, t.detections, t.assigned,
               t.ambiguous_gates, t.epipolar_resolutions, t.nn_disagreements, t.roi_searches, t.full_searches);
  return 0;
}

}  // namespace quad::vision::ground
