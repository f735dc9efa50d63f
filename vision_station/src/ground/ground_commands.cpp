#include "quad/vision/ground/ground_commands.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <iostream>
#include <memory>
#include <set>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/ground/csv_table.h"
#include "quad/vision/ground/ground_sim_source.h"
#include "quad/vision/ground/ground_tracker.h"
#include "quad/vision/ground/pose_output.h"
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
  std::snprintf(tail, sizeof tail,
                "},\"ambiguous_gates\":%d,\"epipolar_resolutions\":%d,\"disowned\":%d,\"ms\":%.3f,\"cpu_ms\":%.3f}",
                fix.ambiguous_gates, fix.epipolar_resolutions, fix.disowned, frame.processing_ms, frame.cpu_ms);
  return s + tail;
}


namespace wire = ground_sim_protocol;

wire::VehicleReport vehicle_report(const VehicleFix& fix) {
  wire::VehicleReport r;
  r.id = fix.id;
  r.found = fix.pose ? 1u : 0u;
  r.ambiguous_gates = fix.ambiguous_gates;
  r.epipolar_resolutions = fix.epipolar_resolutions;
  if (fix.pose)
    for (int i = 0; i < 3; ++i) r.ned[i] = fix.pose->position_ned[i];
  for (int k = 0; k < kMarkerColours; ++k)
    for (size_t c = 0; c < wire::kMaxCameras; ++c) {
      const bool has = c < fix.pixels[k].size() && fix.pixels[k][c];
      r.pixels[k][c][0] = has ? static_cast<float>(fix.pixels[k][c]->x) : std::numeric_limits<float>::quiet_NaN();
      r.pixels[k][c][1] = has ? static_cast<float>(fix.pixels[k][c]->y) : std::numeric_limits<float>::quiet_NaN();
    }
  return r;
}

int parse_int(const std::map<std::string, std::string>& options, const std::string& key, int fallback) {
  if (!options.count(key)) return fallback;
  try {
    return std::stoi(options.at(key));
  } catch (const std::exception&) {
    throw CommandUsageError(key + " '" + options.at(key) + "' is not a whole number");
  }
}

// `track --source sim:SOCKET`: frame sets from the simulator, each vehicle's fix to its radio port,
// an answer per set (ground_sim_protocol.h).
int track_live(const std::map<std::string, std::string>& options, GroundTracker& tracker, const TrackerConfig& config,
               std::ostream* jsonl) {
  const std::string& source = options.at("--source");
  if (source.rfind("sim:", 0) != 0 || source.size() <= 4)
    throw CommandUsageError("--source '" + source + "': the live source of track is sim:SOCKET");
  std::vector<int> ids;
  for (const VehicleStart& v : config.vehicles) ids.push_back(v.id);
  std::unique_ptr<PoseLinks> links;
  if (options.count("--radio")) {
    links = std::make_unique<PoseLinks>(options.at("--radio"), parse_int(options, "--baud", 57600), ids,
                                        parse_pose_message(options.count("--message") ? options.at("--message")
                                                                                       : "vision_position_estimate"));
  }
  GroundSimSource sim(source.substr(4), std::chrono::milliseconds(parse_int(options, "--timeout-ms", 5000)));
  const double status_s = parse_int(options, "--status-s", 1);
  GroundFrameSet set;
  int sets = 0, sets_since = 0;
  double ms_since = 0.0;
  auto last_status = std::chrono::steady_clock::now();
  while (sim.read(set)) {
    const auto start = std::chrono::steady_clock::now();
    // Frames of free-running cameras differ in capture time: the set stands for their mean time.
    double mean_us = 0.0;
    for (int64_t t : set.capture_time_us) mean_us += static_cast<double>(t) / set.capture_time_us.size();
    const int64_t time_us = std::llround(mean_us);
    const FrameSetResult result = tracker.process(set.images, time_us);
    std::vector<wire::VehicleReport> reports;
    for (const VehicleFix& fix : result.vehicles) {
      if (fix.pose && links) links->send(fix.id, *fix.pose, time_us);
      reports.push_back(vehicle_report(fix));
      if (jsonl) *jsonl << fix_json(fix, result) << "\n";
    }
    wire::SetAnswer answer;
    answer.vehicles = static_cast<uint32_t>(reports.size());
    answer.sequence = set.sequence;
    answer.fixes_sent = links ? links->frames_sent() : 0;
    answer.processing_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
    answer.cpu_us = result.cpu_ms * 1000.0;
    answer.fix_time_us = time_us;
    sim.answer(answer, reports);
    ++sets;
    ++sets_since;
    ms_since += answer.processing_us / 1000.0;
    if (std::chrono::steady_clock::now() - last_status > std::chrono::duration<double>(status_s)) {
      last_status = std::chrono::steady_clock::now();
      std::fprintf(stderr, "track: %d frame sets, %.2f ms per set, fixes sent %llu dropped %llu\n", sets,
                   sets_since ? ms_since / sets_since : 0.0, static_cast<unsigned long long>(links ? links->frames_sent() : 0),
                   static_cast<unsigned long long>(links ? links->frames_dropped() : 0));
      sets_since = 0;
      ms_since = 0.0;
    }
  }
  const AssociationStats& t = tracker.totals();
  std::fprintf(stderr,
               "track: end of the simulator's stream after %d frame sets; detections %d, assigned %d, ambiguous gates %d, "
               "epipolar resolutions %d (nearest neighbour alone would differ in %d)\n",
               sets, t.detections, t.assigned, t.ambiguous_gates, t.epipolar_resolutions, t.nn_disagreements);
  return 0;
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
  if (options.count("--source")) {
    if (options.count("--frames")) throw CommandUsageError("--frames and --source exclude each other");
    std::unique_ptr<std::ofstream> jsonl;
    if (options.count("--out")) {
      jsonl = std::make_unique<std::ofstream>(options.at("--out"));
      if (!*jsonl) throw std::runtime_error(options.at("--out") + ": cannot write");
    }
    GroundTracker live(rig, config, settings);
    return track_live(options, live, config, jsonl.get());
  }
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
