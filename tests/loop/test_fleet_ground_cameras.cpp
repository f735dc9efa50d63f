// Several vehicles on the ground cameras, in ctest: the simulator renders the fixed room cameras seeing
// every vehicle's colour balls, one separate `vision_station track --source sim:` process (its room
// calibrated by `calibrate-room` on rendered boards, never given the cameras) tracks all of them, and each
// vehicle's VISION_POSITION_ESTIMATE crosses that vehicle's own emulated radio to its quad_firmware.
//
// The figures are not taken on trust: the shared gates and epipolar resolutions are counted here from the
// station's own output (ground_track.jsonl) and compared with the simulator's summary; every pixel the
// station associated is checked here against the vehicles' true poses (each vehicle's log.csv) projected
// by OpenCV through the station's room calibration; the separation is measured here from the logged
// truths. A run that produced no frame sets, no fixes or no hold samples fails.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "loop_session.h"
#include "loop_summary.h"
#include "quad/sim/fleet_session.h"
#include "quad/sim/scenario.h"

namespace quad::sim {
namespace {

constexpr double kHullTouchingM = 0.78;  // two 0.39 m collision hulls (fleet_model.cpp)

std::string run_dir(const std::string& name) {
  return std::string(::testing::TempDir()) + "/quad_fleet_ground_" + name + "_" + std::to_string(getpid());
}

SessionResult fly(const Scenario& s, const std::string& out) {
  return run_fleet_session(s, loop_session_options(out));
}

// One vehicle's logged truth (log.csv): time, NED position, ZYX angles.
struct Truth {
  std::vector<double> t;
  std::vector<cv::Vec3d> p, euler;
  // Linear interpolation at time s (rows every 10 ms).
  void at(double s, cv::Vec3d& pos, cv::Vec3d& angles) const {
    size_t i = 1;
    while (i + 1 < t.size() && t[i] < s) ++i;
    const double w = std::clamp((s - t[i - 1]) / (t[i] - t[i - 1]), 0.0, 1.0);
    pos = p[i - 1] * (1.0 - w) + p[i] * w;
    angles = euler[i - 1] * (1.0 - w) + euler[i] * w;
  }
};

Truth read_truth(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::map<std::string, size_t> col;
  {
    std::stringstream header(line);
    std::string name;
    for (size_t k = 0; std::getline(header, name, ','); ++k) col[name] = k;
  }
  Truth truth;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream row(line);
    std::string cell;
    while (std::getline(row, cell, ',')) v.push_back(std::strtod(cell.c_str(), nullptr));
    if (v.size() < col.size()) continue;
    truth.t.push_back(v[col.at("t")]);
    truth.p.emplace_back(v[col.at("true_n")], v[col.at("true_e")], v[col.at("true_d")]);
    truth.euler.emplace_back(v[col.at("true_roll")], v[col.at("true_pitch")], v[col.at("true_yaw")]);
  }
  return truth;
}

cv::Matx33d rotation_zyx(const cv::Vec3d& e) {  // R_IB from roll, pitch, yaw
  const double cr = std::cos(e[0]), sr = std::sin(e[0]), cp = std::cos(e[1]), sp = std::sin(e[1]);
  const double cy = std::cos(e[2]), sy = std::sin(e[2]);
  return cv::Matx33d(cy, -sy, 0, sy, cy, 0, 0, 0, 1) * cv::Matx33d(cp, 0, sp, 0, 1, 0, -sp, 0, cp) *
         cv::Matx33d(1, 0, 0, 0, cr, -sr, 0, sr, cr);
}

struct RoomCamera {
  cv::Mat K, D, rvec, t, R;
};

std::vector<RoomCamera> read_room(const std::string& path) {
  cv::FileStorage fs(path, cv::FileStorage::READ);
  std::vector<RoomCamera> cameras;
  if (!fs.isOpened()) return cameras;
  for (int k = 0; k < static_cast<int>(fs["cameras"]); ++k) {
    RoomCamera c;
    const std::string p = "camera_" + std::to_string(k) + "_";
    fs[p + "K"] >> c.K;
    fs[p + "D"] >> c.D;
    fs[p + "R_CI"] >> c.R;
    fs[p + "t_CI"] >> c.t;
    cv::Rodrigues(c.R, c.rvec);
    cameras.push_back(c);
  }
  return cameras;
}

// One line of the station's ground_track.jsonl (docs/vision_station.md, "Output").
struct TrackLine {
  int id = 0;
  int64_t time_us = 0;
  bool found = false;
  int ambiguous = 0, epipolar = 0;
  std::map<std::string, std::vector<std::optional<cv::Point2d>>> pixels;  // colour -> per camera
};

double field(const std::string& line, const std::string& key) {
  const size_t at = line.find("\"" + key + "\":");
  return at == std::string::npos ? NAN : std::strtod(line.c_str() + at + key.size() + 3, nullptr);
}

TrackLine parse_line(const std::string& line) {
  TrackLine l;
  l.id = static_cast<int>(field(line, "id"));
  l.time_us = static_cast<int64_t>(field(line, "time_us"));
  l.found = line.find("\"found\":true") != std::string::npos;
  l.ambiguous = static_cast<int>(field(line, "ambiguous_gates"));
  l.epipolar = static_cast<int>(field(line, "epipolar_resolutions"));
  for (const char* colour : {"red", "green", "blue", "yellow"}) {
    size_t at = line.find(std::string("\"") + colour + "\":[", line.find("\"pixels\""));
    if (at == std::string::npos) continue;
    at += std::string(colour).size() + 4;
    auto& cams = l.pixels[colour];
    while (at < line.size() && line[at] != ']') {
      if (line.compare(at, 4, "null") == 0) {
        cams.emplace_back(std::nullopt);
        at += 4;
      } else if (line[at] == '[') {
        char* end = nullptr;
        const double u = std::strtod(line.c_str() + at + 1, &end);
        const double v = std::strtod(end + 1, &end);
        cams.emplace_back(cv::Point2d(u, v));
        at = static_cast<size_t>(end - line.c_str()) + 1;
      }
      if (at < line.size() && line[at] == ',') ++at;
    }
  }
  return l;
}

struct Checked {
  size_t lines = 0, sets = 0, ambiguous_sets = 0, pixels = 0, wrong = 0;
  long epipolar = 0, ambiguous_gates = 0;
  std::map<int, size_t> found;  // per vehicle id
};

// Every associated pixel against the true balls: wrong when it lies off its own ball's image (radius + 3
// px) or when another vehicle's ball of that colour projects nearer to it.
Checked check_track(const std::string& run, const Scenario& s) {
  Checked c;
  const std::vector<RoomCamera> cameras = read_room(run + "/room_calib.yaml");
  EXPECT_GE(cameras.size(), 2u) << run << "/room_calib.yaml";
  std::map<int, size_t> index;
  std::vector<Truth> truth;
  for (size_t i = 0; i < s.vehicles.size(); ++i) {
    index[s.vehicles[i].system_id] = i;
    truth.push_back(read_truth(run + "/" + s.vehicles[i].name + "/log.csv"));
    EXPECT_GT(truth.back().t.size(), 100u) << s.vehicles[i].name;
  }
  std::ifstream in(run + "/ground_track.jsonl");
  std::set<int64_t> sets, ambiguous;
  std::string line;
  while (std::getline(in, line)) {
    const TrackLine l = parse_line(line);
    ++c.lines;
    sets.insert(l.time_us);
    if (l.ambiguous > 0) ambiguous.insert(l.time_us);
    c.ambiguous_gates += l.ambiguous;
    c.epipolar += l.epipolar;
    if (l.found) ++c.found[l.id];
    if (!index.count(l.id) || cameras.empty()) continue;
    const double t = 1e-6 * static_cast<double>(l.time_us);
    std::vector<cv::Vec3d> pos(truth.size()), angles(truth.size());
    for (size_t i = 0; i < truth.size(); ++i) truth[i].at(t, pos[i], angles[i]);
    for (const auto& [colour, per_camera] : l.pixels) {
      // The ball of this colour on every vehicle, in the room.
      std::vector<cv::Point3d> balls;
      std::vector<double> radius;
      for (size_t i = 0; i < truth.size(); ++i)
        for (const Marker& m : s.vehicles[i].markers)
          if (m.colour == colour) {
            const cv::Vec3d body(m.position_frd_m.x(), m.position_frd_m.y(), m.position_frd_m.z());
            const cv::Vec3d p = pos[i] + rotation_zyx(angles[i]) * body;
            balls.emplace_back(p[0], p[1], p[2]);
            radius.push_back(m.radius_m);
          }
      for (size_t k = 0; k < per_camera.size() && k < cameras.size(); ++k) {
        if (!per_camera[k]) continue;
        std::vector<cv::Point2d> image;
        cv::projectPoints(balls, cameras[k].rvec, cameras[k].t, cameras[k].K, cameras[k].D, image);
        const size_t own = index.at(l.id);
        const cv::Mat in_camera = cameras[k].R * cv::Mat(cv::Vec3d(balls[own].x, balls[own].y, balls[own].z)) + cameras[k].t;
        const double r_px = cameras[k].K.at<double>(0, 0) * radius[own] / in_camera.at<double>(2);
        const double d_own = cv::norm(*per_camera[k] - image[own]);
        bool wrong = d_own > r_px + 3.0;
        for (size_t o = 0; o < image.size(); ++o)
          if (o != own && cv::norm(*per_camera[k] - image[o]) < d_own) wrong = true;
        ++c.pixels;
        if (wrong) {
          ++c.wrong;
          if (c.wrong <= 5)
            std::printf("association error: vehicle %d, %s, camera %zu, t %.3f s: %.1f px from its own ball\n", l.id,
                        colour.c_str(), k, t, d_own);
        }
      }
    }
  }
  c.sets = sets.size();
  c.ambiguous_sets = ambiguous.size();
  return c;
}

// Smallest distance between two vehicles' logged true centres (log.csv rows share their times).
double min_separation(const std::string& run, const Scenario& s) {
  std::vector<Truth> truth;
  for (const FleetVehicle& v : s.vehicles) truth.push_back(read_truth(run + "/" + v.name + "/log.csv"));
  double best = INFINITY;
  for (size_t a = 0; a < truth.size(); ++a)
    for (size_t b = a + 1; b < truth.size(); ++b)
      for (size_t r = 0; r < truth[a].p.size() && r < truth[b].p.size(); ++r)
        best = std::min(best, cv::norm(truth[a].p[r] - truth[b].p[r]));
  return best;
}

TEST(FleetGroundCameras, TwoVehiclesHoldOnTheRoomCameras) {
  const std::string out = run_dir("pair");
  // The shipped scenario, shortened: a 16 s hold and no landing.
  const Scenario s = load_scenario(std::string(QUAD_SIM_SOURCE_DIR) + "/scenarios/fleet_ground_pair.yaml",
                                   {{"duration_s", "29"}, {"commands.3.at_s", "28.5"}, {"metrics.hold_end_s", "28"}});
  const SessionResult r = fly(s, out);
  ASSERT_TRUE(r.complete) << r.reason;
  const std::string j = slurp(out + "/summary.json");
  std::printf("[figure] fleet_ground_pair 16 s hold: %s\n", j.c_str());
  EXPECT_EQ(json_number(j, {"collisions", "count"}), 0.0);
  const double sets = json_number(j, {"ground_station", "sets_captured"});
  EXPECT_NEAR(sets, 29.0 * 30.0, 2.0);
  EXPECT_EQ(json_number(j, {"ground_station", "association_errors"}), 0.0);
  const Checked c = check_track(out, s);
  std::printf("[figure] station output: %zu lines, %zu sets, %zu pixels checked, %zu wrong\n", c.lines, c.sets, c.pixels, c.wrong);
  EXPECT_GE(static_cast<double>(c.sets), sets - 2.0);
  EXPECT_GT(c.pixels, static_cast<size_t>(0.98 * 2 * 8 * sets));
  EXPECT_EQ(c.wrong, 0u);
  for (const char* v : {"west", "east"}) {
    EXPECT_LE(json_number(j, {"vehicles", v, "hold", "horizontal", "std_2d"}), 0.02) << v;
    EXPECT_GT(json_number(j, {"vehicles", v, "hold", "samples"}), 1590.0) << v;
    EXPECT_GT(json_number(j, {"vehicles", v, "ground_station", "fixes"}), 0.98 * sets) << v;
    const double latency = json_number(j, {"vehicles", v, "ground_station", "fix_latency_s", "median"});
    EXPECT_GT(latency, 0.030) << v;
    EXPECT_LT(latency, 0.080) << v;
  }
  EXPECT_EQ(j.find("\"crashed\": true"), std::string::npos) << j;
}

TEST(FleetGroundCameras, FourVehiclesSwapCornersThroughSharedGates) {
  const std::string out = run_dir("swap");
  const Scenario s = load_scenario(std::string(QUAD_SIM_SOURCE_DIR) + "/scenarios/fleet_ground_swap.yaml");
  const SessionResult r = fly(s, out);
  ASSERT_TRUE(r.complete) << r.reason;
  const std::string j = slurp(out + "/summary.json");
  std::printf("[figure] fleet_ground_swap: %s\n", j.c_str());
  const Checked c = check_track(out, s);
  const double separation = min_separation(out, s);
  std::printf("[figure] station output: %zu lines, %zu sets, %zu with a shared gate, %ld shared gates, %ld epipolar "
              "resolutions, %zu pixels checked, %zu wrong; min separation %.3f m\n",
              c.lines, c.sets, c.ambiguous_sets, c.ambiguous_gates, c.epipolar, c.pixels, c.wrong, separation);
  const double sets = json_number(j, {"ground_station", "sets_captured"});
  EXPECT_GT(sets, 0.95 * s.duration_s * 30.0);
  EXPECT_GE(static_cast<double>(c.sets), sets - 2.0);
  EXPECT_GE(static_cast<double>(c.lines), 4.0 * (sets - 2.0));
  // The hard case happened, and the station settled it with the epipolar constraint, without error.
  EXPECT_GE(c.ambiguous_sets, 50u);
  EXPECT_GT(c.epipolar, 0);
  EXPECT_EQ(static_cast<double>(c.ambiguous_sets), json_number(j, {"ground_station", "ambiguous_sets"}));
  EXPECT_EQ(static_cast<double>(c.epipolar), json_number(j, {"ground_station", "epipolar_resolutions"}));
  EXPECT_GT(c.pixels, static_cast<size_t>(0.9 * 4 * 8 * sets));
  EXPECT_EQ(c.wrong, 0u);
  EXPECT_EQ(json_number(j, {"ground_station", "association_errors"}), 0.0);
  // No collision: no hull contact in the physics, and the logged centres never closer than the hulls.
  EXPECT_EQ(json_number(j, {"collisions", "count"}), 0.0);
  EXPECT_GT(separation, kHullTouchingM);
  EXPECT_EQ(j.find("\"crashed\": true"), std::string::npos) << j;
  // Each swapped and holds at the opposite corner on its fixes.
  for (const char* v : {"nw", "se", "ne", "sw"}) {
    EXPECT_GT(json_number(j, {"vehicles", v, "hold", "samples"}), 390.0) << v;  // 24-28 s at 100 Hz
    EXPECT_LT(json_number(j, {"vehicles", v, "tracking_error_m", "rms"}), 0.05) << v;
    EXPECT_GT(static_cast<double>(c.found.count(static_cast<int>(json_number(j, {"vehicles", v, "system_id"})))
                                      ? c.found.at(static_cast<int>(json_number(j, {"vehicles", v, "system_id"})))
                                      : 0),
              0.9 * sets)
        << v;
  }
}

}  // namespace
}  // namespace quad::sim
