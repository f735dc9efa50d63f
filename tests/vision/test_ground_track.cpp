// The ground-camera mode end to end, against scenes it did not make: tools/ground_eval draws the room
// cameras, the calibration boards and the vehicles' colour markers with its own camera model; the test
// calibrates the room with `vision_station calibrate-room` (never given the true cameras), tracks with
// `vision_station track` and scores the JSON lines against the generator's truth: position and attitude
// error per vehicle, association errors (a marker pixel given to a vehicle that is another vehicle's
// marker), and the epipolar resolutions where two same-colour markers shared a gate.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "ground_scenes.h"
#include "command_output.h"

namespace {

namespace fs = std::filesystem;
using namespace ground_eval;

// A minimal JSON reader for the station's output lines (objects, arrays, numbers, strings, literals).
struct Json {
  enum Kind { kNull, kBool, kNumber, kString, kArray, kObject } kind = kNull;
  double number = 0.0;
  bool boolean = false;
  std::string text;
  std::vector<Json> items;
  std::map<std::string, Json> fields;
  const Json& operator[](const std::string& key) const {
    static const Json null;
    const auto it = fields.find(key);
    return it == fields.end() ? null : it->second;
  }
};

class JsonParser {
 public:
  explicit JsonParser(const std::string& s) : s_(s) {}
  Json parse() {
    Json v = value();
    skip();
    if (i_ != s_.size()) throw std::runtime_error("trailing characters in " + s_);
    return v;
  }

 private:
  void skip() {
    while (i_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[i_]))) ++i_;
  }
  void expect(char c) {
    skip();
    if (i_ >= s_.size() || s_[i_] != c) throw std::runtime_error(std::string("expected '") + c + "' in " + s_);
    ++i_;
  }
  std::string string_token() {
    expect('"');
    const size_t end = s_.find('"', i_);
    std::string out = s_.substr(i_, end - i_);
    i_ = end + 1;
    return out;
  }
  Json value() {
    skip();
    Json v;
    const char c = s_.at(i_);
    if (c == '{') {
      v.kind = Json::kObject;
      ++i_;
      skip();
      if (s_[i_] == '}') return ++i_, v;
      do {
        const std::string key = string_token();
        expect(':');
        v.fields[key] = value();
        skip();
      } while (s_[i_++] == ',');
    } else if (c == '[') {
      v.kind = Json::kArray;
      ++i_;
      skip();
      if (s_[i_] == ']') return ++i_, v;
      do {
        v.items.push_back(value());
        skip();
      } while (s_[i_++] == ',');
    } else if (c == '"') {
      v.kind = Json::kString;
      v.text = string_token();
    } else if (s_.compare(i_, 4, "null") == 0) {
      i_ += 4;
    } else if (s_.compare(i_, 4, "true") == 0) {
      v.kind = Json::kBool;
      v.boolean = true;
      i_ += 4;
    } else if (s_.compare(i_, 5, "false") == 0) {
      v.kind = Json::kBool;
      i_ += 5;
    } else {
      v.kind = Json::kNumber;
      size_t used = 0;
      v.number = std::stod(s_.substr(i_, 40), &used);
      i_ += used;
    }
    return v;
  }
  const std::string& s_;
  size_t i_ = 0;
};

std::string run(const std::string& command) {
  std::printf("[vision] $ %s\n", command.c_str());
  const quad::test::CommandOutput r = quad::test::run_command(command);
  if (r.status != 0) throw std::runtime_error(command + " failed (" + std::to_string(r.status) + "):\n" + r.out);
  return r.out;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::min(v.size() - 1.0, std::floor(p * (v.size() - 1) + 0.5)))];
}

const char* kColours[4] = {"red", "green", "blue", "yellow"};

struct Score {
  std::map<int, std::vector<double>> position_m, attitude_deg;
  std::map<int, int> frames, found;
  int association_errors = 0;
  int assigned_pixels = 0;
  int ambiguous_gates = 0;
  int epipolar_resolutions = 0;
  std::vector<double> ms, cpu_ms;
};

// The truth's marker nearest to an assigned pixel among all vehicles' visible markers of that colour.
Score score(const std::string& jsonl, const std::vector<FrameTruth>& truth) {
  std::map<int64_t, const FrameTruth*> by_time;
  for (const FrameTruth& f : truth) by_time[f.time_us] = &f;
  Score s;
  std::ifstream in(jsonl);
  std::string line;
  while (std::getline(in, line)) {
    const Json j = JsonParser(line).parse();
    const FrameTruth& f = *by_time.at(static_cast<int64_t>(j["time_us"].number));
    const int id = static_cast<int>(j["id"].number);
    size_t v = 0;
    while (v < f.vehicles.size() && f.vehicles[v].id != id) ++v;
    EXPECT_LT(v, f.vehicles.size()) << "unknown vehicle id " << id;
    if (v == f.vehicles.size()) continue;
    ++s.frames[id];
    s.ms.push_back(j["ms"].number);
    s.cpu_ms.push_back(j["cpu_ms"].number);
    s.ambiguous_gates += static_cast<int>(j["ambiguous_gates"].number);
    s.epipolar_resolutions += static_cast<int>(j["epipolar_resolutions"].number);
    if (j["found"].boolean) {
      ++s.found[id];
      const Json& p = j["ned"];
      const cv::Vec3d est(p.items[0].number, p.items[1].number, p.items[2].number);
      s.position_m[id].push_back(cv::norm(est - f.vehicles[v].ned));
      const Json& q = j["q_IB"];
      const cv::Vec4d qe(q.items[0].number, q.items[1].number, q.items[2].number, q.items[3].number);
      const cv::Vec4d qt = quaternion_of(f.vehicles[v].R_IB);
      s.attitude_deg[id].push_back(2.0 * std::acos(std::min(1.0, std::abs(qe.dot(qt)))) * 180.0 / CV_PI);
    }
    for (int k = 0; k < 4; ++k) {
      const Json& per_camera = j["pixels"][kColours[k]];
      for (size_t c = 0; c < per_camera.items.size(); ++c) {
        if (per_camera.items[c].kind != Json::kArray) continue;
        ++s.assigned_pixels;
        const cv::Point2d px(per_camera.items[c].items[0].number, per_camera.items[c].items[1].number);
        double own = cv::norm(px - f.markers[v][c][k].pixel), other = 1e9;
        for (size_t o = 0; o < f.vehicles.size(); ++o) {
          if (o != v && f.markers[o][c][k].visible > 0.0) other = std::min(other, cv::norm(px - f.markers[o][c][k].pixel));
        }
        if (other < own) {
          ++s.association_errors;
          std::printf("[vision] association error: t=%lld vehicle %d %s camera %zu: %.1f px from its own marker, %.1f "
                      "from another's\n", static_cast<long long>(f.time_us), id, kColours[k], c, own, other);
        }
      }
    }
  }
  return s;
}

class GroundTrack : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("ground_track_" + std::to_string(::getpid())));
    fs::create_directories(*dir_);
    cameras_ = new std::vector<SceneCamera>(make_room_cameras(RoomSpec()));
    write_calibration_set((*dir_ / "boards").string(), *cameras_, BoardSpec(), 12, 7);
    calibration_output_ = new std::string(run(std::string(VISION_STATION_EXE) + " calibrate-room --images " +
                                              (*dir_ / "boards").string() + " --out " + room()));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
    delete cameras_;
    delete calibration_output_;
  }
  static std::string room() { return (*dir_ / "room.yaml").string(); }

  Score track(Scenario scenario, int frames, const std::string& extra = "") {
    SceneOptions options;
    options.scenario = scenario;
    options.frames = frames;
    options.seed = 11 + static_cast<int>(scenario);
    const fs::path set = *dir_ / scenario_name(scenario);
    const std::vector<FrameTruth> truth = write_scene_set(set.string(), *cameras_, VehicleModel(), options);
    const std::string out = (set / "track.jsonl").string();
    std::printf("%s", run(std::string(VISION_STATION_EXE) + " track --room " + room() + " --vehicles " +
                          (set / "vehicles.yaml").string() + " --frames " + (set / "frames.csv").string() + " --out " +
                          out + extra).c_str());
    Score s = score(out, truth);
    for (const auto& [id, errors] : s.position_m) {
      std::printf("[vision] %s%s vehicle %d: found %d of %d; position error median %.2f mm, p95 %.2f mm; attitude "
                  "error median %.3f deg, p95 %.3f deg\n", scenario_name(scenario), extra.c_str(), id, s.found[id],
                  s.frames[id], 1e3 * percentile(errors, 0.5), 1e3 * percentile(errors, 0.95),
                  percentile(s.attitude_deg[id], 0.5), percentile(s.attitude_deg[id], 0.95));
    }
    std::printf("[vision] %s%s: association errors %d of %d assigned pixels; shared gates %d, epipolar "
                "resolutions %d (both summed over the vehicles in each gate); processing per frame set median %.2f ms "
                "wall, %.2f ms CPU\n", scenario_name(scenario), extra.c_str(), s.association_errors,
                s.assigned_pixels, s.ambiguous_gates, s.epipolar_resolutions, percentile(s.ms, 0.5),
                percentile(s.cpu_ms, 0.5));
    return s;
  }

  static void expect_accuracy(Score& s, double min_found, double median_mm, double p95_mm, double median_deg,
                              double p95_deg) {
    ASSERT_FALSE(s.frames.empty());
    for (const auto& [id, frames] : s.frames) {
      EXPECT_GE(s.found[id], min_found * frames) << "vehicle " << id;
      EXPECT_LE(1e3 * percentile(s.position_m[id], 0.5), median_mm) << "vehicle " << id;
      EXPECT_LE(1e3 * percentile(s.position_m[id], 0.95), p95_mm) << "vehicle " << id;
      EXPECT_LE(percentile(s.attitude_deg[id], 0.5), median_deg) << "vehicle " << id;
      EXPECT_LE(percentile(s.attitude_deg[id], 0.95), p95_deg) << "vehicle " << id;
    }
  }

  static fs::path* dir_;
  static std::vector<SceneCamera>* cameras_;
  static std::string* calibration_output_;
};

fs::path* GroundTrack::dir_ = nullptr;
std::vector<SceneCamera>* GroundTrack::cameras_ = nullptr;
std::string* GroundTrack::calibration_output_ = nullptr;

// The calibrated cameras, read with OpenCV's FileStorage, against the generator's: centre and the
// projection of points spread over the flight volume.
TEST_F(GroundTrack, RoomCalibrationFromBoardsAtKnownFloorPlaces) {
  std::printf("%s", calibration_output_->c_str());
  cv::FileStorage file(room(), cv::FileStorage::READ);
  ASSERT_TRUE(file.isOpened());
  ASSERT_EQ(static_cast<int>(file["cameras"]), 2);
  std::vector<cv::Point3d> volume;
  for (double n = -0.5; n <= 1.0; n += 0.25) {
    for (double e = -0.5; e <= 1.0; e += 0.25) {
      for (double d = -1.2; d <= -0.4; d += 0.4) volume.emplace_back(n, e, d);
    }
  }
  for (int c = 0; c < 2; ++c) {
    const std::string p = "camera_" + std::to_string(c) + "_";
    cv::Mat K, D, R, t;
    file[p + "K"] >> K;
    file[p + "D"] >> D;
    file[p + "R_CI"] >> R;
    file[p + "t_CI"] >> t;
    const cv::Mat centre = -R.t() * t;
    const double centre_error = cv::norm(cv::Vec3d(centre) - (*cameras_)[c].centre_ned);
    std::vector<cv::Point2d> calibrated, truth;
    cv::Mat rvec;
    cv::Rodrigues(R, rvec);
    cv::projectPoints(volume, rvec, t, K, D, calibrated);
    cv::projectPoints(volume, (*cameras_)[c].rvec, (*cameras_)[c].tvec, (*cameras_)[c].K, (*cameras_)[c].distortion, truth);
    std::vector<double> errors;
    for (size_t i = 0; i < volume.size(); ++i) {
      if (truth[i].x >= 10 && truth[i].y >= 10 && truth[i].x < 1014 && truth[i].y < 758) {
        errors.push_back(cv::norm(calibrated[i] - truth[i]));
      }
    }
    std::printf("[vision] camera %d: centre error %.1f mm; reprojection of %zu flight-volume points vs the true "
                "camera: median %.3f px, p95 %.3f px, max %.3f px\n", c, 1e3 * centre_error, errors.size(),
                percentile(errors, 0.5), percentile(errors, 0.95), percentile(errors, 1.0));
    EXPECT_LT(centre_error, 0.02);
    EXPECT_GT(errors.size(), 20u);
    EXPECT_LT(percentile(errors, 0.5), 0.3);
    EXPECT_LT(percentile(errors, 0.95), 0.6);
    EXPECT_LT(percentile(errors, 1.0), 1.5);
  }
}

TEST_F(GroundTrack, OneVehicleFlyingAFigure) {
  Score s = track(Scenario::kSingle, 45);
  expect_accuracy(s, 0.98, 5.0, 10.0, 1.0, 2.0);
  EXPECT_EQ(s.association_errors, 0);
}

TEST_F(GroundTrack, TwoVehiclesSideBySide) {
  Score s = track(Scenario::kPair, 30);
  expect_accuracy(s, 0.98, 5.0, 10.0, 1.0, 2.0);
  EXPECT_EQ(s.association_errors, 0);
}

// Two vehicles pass each other on one camera's line of sight: same-colour markers share gates in that
// camera, and the other camera's view (the epipolar constraint) settles which is which.
TEST_F(GroundTrack, TwoVehiclesCrossingResolvedByTheEpipolarConstraint) {
  Score s = track(Scenario::kCrossing, 60);
  expect_accuracy(s, 0.9, 5.0, 15.0, 1.0, 3.0);
  EXPECT_EQ(s.association_errors, 0);
  EXPECT_GT(s.ambiguous_gates, 0);
  EXPECT_GT(s.epipolar_resolutions, 0);
}

TEST_F(GroundTrack, FourVehiclesTwoCrossings) {
  Score s = track(Scenario::kFour, 75);
  expect_accuracy(s, 0.9, 5.0, 15.0, 1.0, 3.0);
  EXPECT_EQ(s.association_errors, 0);
  EXPECT_GT(s.epipolar_resolutions, 0);
}

}  // namespace

namespace {

// A valid room file (the generator's true cameras), written with OpenCV's FileStorage.
std::string room_for_input_test(const fs::path& dir) {
  const std::string path = (dir / "valid_room.yaml").string();
  cv::FileStorage file(path, cv::FileStorage::WRITE);
  const auto cameras = make_room_cameras(RoomSpec());
  file << "cameras" << static_cast<int>(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    const std::string p = "camera_" + std::to_string(c) + "_";
    cv::Matx33d R;
    cv::Rodrigues(cameras[c].rvec, R);
    file << p + "image_size" << cameras[c].size << p + "K" << cv::Mat(cameras[c].K) << p + "D"
         << cv::Mat(cameras[c].distortion) << p + "R_CI" << cv::Mat(R) << p + "t_CI" << cv::Mat(cameras[c].tvec);
  }
  return path;
}

// Exit code and output of a command expected to fail.
std::pair<int, std::string> run_failing(const std::string& command) {
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen((command + " 2>&1").c_str(), "r"), pclose);
  std::string out;
  char buffer[1024];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe.get())) > 0) out.append(buffer, n);
  const int status = pclose(pipe.release());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

TEST(GroundTrackInput, BadFilesAreErrorsNamingTheFileAndKey) {
  const fs::path dir = fs::temp_directory_path() / ("ground_track_bad_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string exe = VISION_STATION_EXE;
  {
    std::ofstream(dir / "room.yaml") << "%YAML:1.0\n---\ncameras: 2\ncamera_0_image_size: [ 1024, 768 ]\n";
    std::ofstream(dir / "vehicles.yaml") << "%YAML:1.0\n---\nmarker_red: [ 0.2, 0.0 ]\n";
    std::ofstream(dir / "frames.csv") << "time_us,camera_0,camera_1\n1000,a.png\n";
  }
  auto [code, out] = run_failing(exe + " track --room " + (dir / "room.yaml").string() + " --vehicles " +
                                 (dir / "vehicles.yaml").string() + " --frames " + (dir / "frames.csv").string());
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("room.yaml: missing key 'camera_0_K'"), std::string::npos) << out;
  std::tie(code, out) = run_failing(exe + " track --room " + room_for_input_test(dir) + " --vehicles " +
                                    (dir / "vehicles.yaml").string() + " --frames " + (dir / "frames.csv").string());
  EXPECT_EQ(code, 1);
  EXPECT_NE(out.find("vehicles.yaml: key 'marker_red' must be a list of 3 numbers"), std::string::npos) << out;
  std::tie(code, out) = run_failing(exe + " track --room " + room_for_input_test(dir));
  EXPECT_EQ(code, 2);
  EXPECT_NE(out.find("missing --vehicles"), std::string::npos) << out;
  fs::remove_all(dir);
}

}  // namespace
