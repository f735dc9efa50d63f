// vision_station: stereo calibration, offline star detection and the live station.
//   vision_station calibrate --images DIR | --source v4l2:/dev/A,/dev/B [--count N]
//                            [--board 9x6] [--square 0.025] --out calib.yaml
//   (--calib takes one calibration file, or OpenCV's sample pair INTRINSICS.yml,EXTRINSICS.yml)
//   vision_station detect --calib FILE (--left L.png --right R.png | --pairs LIST.csv) [--settings FILE]
//   vision_station run --calib FILE --source SPEC [--out /dev/ttyUSB0 --baud 57600] [--show]
//                      [--show-screenshot FILE.png] [--settings FILE] [--timeout-ms 500] [--status-s 1]
//                      [--stats FILE.json]
#include <csignal>
#include <cstdlib>
#include <cstdio>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/highgui.hpp>
#include <opencv2/imgproc.hpp>

#include "quad/vision/chessboard_calibration.h"
#include "quad/vision/fix_output.h"
#include "quad/vision/frame_source.h"
#include "quad/vision/ground/ground_commands.h"
#include "quad/vision/pair_list.h"
#include "quad/vision/settings_file.h"
#include "quad/vision/station.h"
#include "quad/vision/stereo_locator.h"

namespace {

using namespace quad::vision;

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

const char* kUsage =
    "usage:\n"
    "  vision_station calibrate (--images DIR | --source v4l2:/dev/A,/dev/B [--count N]) [--board 9x6]\n"
    "                           [--square 0.025] --out calib.yaml\n"
    "  vision_station detect --calib FILE (--left L.png --right R.png | --pairs LIST.csv) [--settings FILE]\n"
    "  vision_station run --calib FILE --source (files:DIR | v4l2:/dev/A,/dev/B | video:L[@MS],R[@MS] | sim:SOCKET)\n"
    "                     [--out PATH]"
    " [--baud 57600] [--show [--show-screenshot FILE.png]] [--settings FILE]\n"
    "                     [--timeout-ms 500] [--status-s 1] [--stats FILE.json]\n"
    "  vision_station calibrate-room --images DIR [--board 8x6] [--square 0.10] --out room.yaml\n"
    "  vision_station track --room room.yaml --vehicles vehicles.yaml --frames frames.csv [--out FILE.jsonl]\n"
    "                       [--no-epipolar] [--no-roi]\n"
    "  vision_station track --room room.yaml --vehicles vehicles.yaml --source sim:SOCKET [--radio ID=PATH[,...]]\n"
    "                       [--baud 57600] [--message vision_position_estimate] [--out FILE.jsonl] [--status-s 1]\n"
    "                       [--timeout-ms 5000] [--no-epipolar] [--no-roi]\n"
    "  --calib takes the station's calibration file, or OpenCV's sample pair INTRINSICS.yml,EXTRINSICS.yml\n";

// --key value options; flags listed in `flags` take no value.
std::map<std::string, std::string> parse_options(int argc, char** argv, const std::vector<std::string>& flags) {
  std::map<std::string, std::string> options;
  for (int i = 2; i < argc; ++i) {
    const std::string key = argv[i];
    if (key.rfind("--", 0) != 0) throw UsageError("unexpected argument '" + key + "'");
    if (std::find(flags.begin(), flags.end(), key) != flags.end()) {
      options[key] = "1";
    } else if (i + 1 < argc) {
      options[key] = argv[++i];
    } else {
      throw UsageError(key + " needs a value");
    }
  }
  return options;
}

std::string require(const std::map<std::string, std::string>& options, const std::string& key) {
  const auto it = options.find(key);
  if (it == options.end()) throw UsageError("missing " + key);
  return it->second;
}

double number(const std::map<std::string, std::string>& options, const std::string& key, double fallback) {
  const auto it = options.find(key);
  if (it == options.end()) return fallback;
  try {
    size_t used = 0;
    const double v = std::stod(it->second, &used);
    if (used != it->second.size()) throw std::invalid_argument("");
    return v;
  } catch (const std::exception&) {
    throw UsageError(key + " '" + it->second + "' is not a number");
  }
}

StationSettings settings_from(const std::map<std::string, std::string>& options) {
  const auto it = options.find("--settings");
  return it == options.end() ? StationSettings{} : load_station_settings(it->second);
}

void check_size(const cv::Mat& image, const std::string& path, const StereoCalibration& calibration) {
  if (image.size() != calibration.rig.image_size) {
    throw std::runtime_error(path + ": image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                             " but the calibration is for " + std::to_string(calibration.rig.image_size.width) + "x" +
                             std::to_string(calibration.rig.image_size.height));
  }
}

StereoCalibration calibration_from(const std::map<std::string, std::string>& options) {
  const std::string spec = require(options, "--calib");
  StereoCalibration calibration = load_calibration(spec);
  if (calibration.rectification_computed) {
    std::cerr << "vision_station: " << spec << " has no R1 R2 P1 P2 Q: rectification computed with cv::stereoRectify\n";
  }
  return calibration;
}

int detect(const std::map<std::string, std::string>& options) {
  const StereoCalibration calibration = calibration_from(options);
  const StationSettings settings = settings_from(options);
  std::vector<ImagePair> pairs;
  if (options.count("--pairs")) {
    pairs = read_pair_list(options.at("--pairs"));
  } else {
    pairs.push_back(ImagePair{require(options, "--left"), require(options, "--right"), 0});
  }
  LocatorSettings locator_settings = settings.locator;
  locator_settings.track_roi = false;  // independent pairs
  StereoStarLocator locator(calibration, locator_settings);
  for (const ImagePair& pair : pairs) {
    const cv::Mat left = read_grey_image(pair.left);
    const cv::Mat right = read_grey_image(pair.right);
    check_size(left, pair.left, calibration);
    check_size(right, pair.right, calibration);
    const int64_t start_us = monotonic_us();  // processing only: the images are already decoded
    const StarFix fix = locator.locate(left, right);
    const double ms = (monotonic_us() - start_us) / 1000.0;
    std::string json = fix_json(fix, settings.mount, pairs.size() > 1 ? pair.left + "," + pair.right : "");
    char ms_field[32];
    std::snprintf(ms_field, sizeof ms_field, ",\"ms\":%.3f}", ms);
    json.replace(json.size() - 1, 1, ms_field);
    std::cout << json << "\n";
  }
  return 0;
}

cv::Size parse_board(const std::string& text) {
  int w = 0, h = 0;
  char x = 0;
  if (std::sscanf(text.c_str(), "%d%c%d", &w, &x, &h) != 3 || x != 'x' || w < 2 || h < 2) {
    throw UsageError("--board '" + text + "': expected inner corners as COLSxROWS, e.g. 9x6");
  }
  return cv::Size(w, h);
}

int calibrate(const std::map<std::string, std::string>& options) {
  ChessboardSpec board;
  if (options.count("--board")) board.inner_corners = parse_board(options.at("--board"));
  board.square_m = number(options, "--square", board.square_m);
  const std::string out = require(options, "--out");
  std::unique_ptr<FrameSource> source;
  if (options.count("--images")) {
    source = make_frame_source("files:" + options.at("--images"));
  } else {
    source = make_frame_source(require(options, "--source"));
  }
  const bool live = !options.count("--images");
  const int wanted = static_cast<int>(number(options, "--count", 20));
  std::vector<std::vector<cv::Point2f>> left, right;
  cv::Size size;
  StereoFrame frame;
  int64_t last_kept_us = 0;
  while (!live || static_cast<int>(left.size()) < wanted) {
    const ReadStatus status = source->read(frame, std::chrono::milliseconds(2000));
    if (status == ReadStatus::kEnd) break;
    if (status == ReadStatus::kNoFrame) {
      std::cerr << "calibrate: no frames: " << source->health() << "\n";
      continue;
    }
    if (size.area() == 0) size = frame.left.size();
    if (frame.left.size() != size || frame.right.size() != size) {
      throw std::runtime_error(frame.label + ": image size differs from the first pair");
    }
    // Live: keep a view at most once a second so that the board has moved.
    if (live && frame.capture_time_us - last_kept_us < 1'000'000) continue;
    const auto l = find_chessboard(frame.left, board);
    const auto r = l ? find_chessboard(frame.right, board) : std::nullopt;
    if (!l || !r) {
      if (!live) std::cerr << "calibrate: board not found in both images of " << frame.label << "\n";
      continue;
    }
    left.push_back(*l);
    right.push_back(*r);
    last_kept_us = frame.capture_time_us;
    std::cerr << "calibrate: view " << left.size() << (live ? " of " + std::to_string(wanted) : "") << "\n";
  }
  const StereoCalibrationResult result = calibrate_stereo(left, right, size, board);
  save_calibration(result.calibration, out);
  std::printf("calibrated from %d views: RMS reprojection left %.3f px, right %.3f px, stereo %.3f px; "
              "baseline %.4f m; rectified focal %.1f px; corners seen up to %.1f deg off the left axis; written to %s\n",
              result.pairs, result.rms_left_px, result.rms_right_px, result.rms_stereo_px,
              cv::norm(result.calibration.rig.T), result.calibration.rectified_focal(),
              result.widest_off_axis_rad * 180.0 / CV_PI, out.c_str());
  return 0;
}

volatile std::sig_atomic_t g_stop = 0;

// Rolling statistics for the status line.
struct Status {
  int frames = 0, fixes = 0, stalls = 0;
  StageTimes sum;
  void add(const StarFix& fix) {
    ++frames;
    fixes += fix.found ? 1 : 0;
    sum.threshold_morphology_us += fix.times.threshold_morphology_us;
    sum.contours_filters_us += fix.times.contours_filters_us;
    sum.rectify_points_us += fix.times.rectify_points_us;
    sum.triangulation_us += fix.times.triangulation_us;
  }
  std::string line(double seconds) const {
    const double n = std::max(frames, 1);
    char buffer[320];
    std::snprintf(buffer, sizeof buffer,
                  "%.1f fps, detection %.0f %%, latency us: threshold+morph %.0f, contours+filters %.0f, "
                  "rectify %.0f, triangulate %.0f%s",
                  frames / seconds, 100.0 * fixes / n, sum.threshold_morphology_us / n, sum.contours_filters_us / n,
                  sum.rectify_points_us / n, sum.triangulation_us / n,
                  stalls > 0 ? (", " + std::to_string(stalls) + " stalls").c_str() : "");
    return buffer;
  }
};

// Skew and dropped frames of a two-clock source, for the status line.
std::string pairing_line(const PairingStats& p) {
  char buffer[256];
  std::snprintf(buffer, sizeof buffer,
                "skew ms mean %.1f max %.1f (limit %.1f), unpaired L %llu R %llu, missing L %llu R %llu",
                p.mean_skew_us() / 1e3, p.max_observed_skew_us() / 1e3, p.max_skew_us / 1e3,
                static_cast<unsigned long long>(p.unpaired[0]), static_cast<unsigned long long>(p.unpaired[1]),
                static_cast<unsigned long long>(p.missing[0]), static_cast<unsigned long long>(p.missing[1]));
  return buffer;
}

// --stats FILE: the run's totals as one JSON object, written at exit.
void write_stats(const std::string& path, const Status& total, const std::optional<PairingStats>& pairing) {
  std::FILE* file = std::fopen(path.c_str(), "w");
  if (file == nullptr) throw std::runtime_error("--stats: cannot write " + path);
  std::fprintf(file, "{\"frames\":%d,\"fixes\":%d,\"stalls\":%d,\"pairing\":%s}\n", total.frames, total.fixes,
               total.stalls, pairing ? pairing->json().c_str() : "null");
  std::fclose(file);
}

const char* kWindow = "vision_station";

// The --show window: both views side by side (left | right, raw pixels), the detected contour in red in
// each, and a green line with the fix (left camera frame, metres) and the processing latency. Returns the
// frame it displayed (for --show-screenshot). Esc in the window ends the run like Ctrl-C.
cv::Mat show(const StereoFrame& frame, const StarFix& fix) {
  cv::Mat views[2];
  for (int i = 0; i < 2; ++i) {
    cv::cvtColor(i == 0 ? frame.left : frame.right, views[i], cv::COLOR_GRAY2BGR);
    const std::vector<cv::Point>& contour = i == 0 ? fix.left_contour : fix.right_contour;
    if (fix.found) cv::polylines(views[i], std::vector<std::vector<cv::Point>>{contour}, true, cv::Scalar(0, 0, 255), 2);
  }
  cv::Mat both;
  cv::hconcat(views[0], views[1], both);
  char text[160];
  if (fix.found) {
    std::snprintf(text, sizeof text, "star (%.3f, %.3f, %.3f) m  %.2f ms", fix.p_left[0], fix.p_left[1], fix.p_left[2],
                  fix.times.total_us() / 1000.0);
  } else {
    std::snprintf(text, sizeof text, "no fix  %.2f ms", fix.times.total_us() / 1000.0);
  }
  cv::putText(both, text, cv::Point(10, 24), cv::FONT_HERSHEY_SIMPLEX, 0.7, cv::Scalar(0, 255, 0), 2);
  cv::imshow(kWindow, both);
  if (cv::waitKey(1) == 27) g_stop = 1;
  return both;
}

int run(const std::map<std::string, std::string>& options) {
  // The display is checked first: without one, nothing is loaded, opened or processed.
  const bool display = options.count("--show") > 0;
  if (display && std::getenv("DISPLAY") == nullptr && std::getenv("WAYLAND_DISPLAY") == nullptr) {
    throw std::runtime_error("--show needs a display (DISPLAY or WAYLAND_DISPLAY is not set)");
  }
  const std::string screenshot = options.count("--show-screenshot") ? options.at("--show-screenshot") : "";
  if (!screenshot.empty() && !display) throw UsageError("--show-screenshot needs --show");
  const StereoCalibration calibration = calibration_from(options);
  const StationSettings settings = settings_from(options);
  std::unique_ptr<FrameSource> source = make_frame_source(require(options, "--source"), settings.max_pair_skew_ms * 1e3);
  const std::string stats_path = options.count("--stats") ? options.at("--stats") : "";
  std::unique_ptr<SerialPort> port;
  std::unique_ptr<FixLink> link;
  if (options.count("--out")) {
    port = std::make_unique<SerialPort>(options.at("--out"), static_cast<int>(number(options, "--baud", 57600)));
    link = std::make_unique<FixLink>(*port, !source->vehicle_clock(), settings.send_covariance);
  }
  const auto timeout = std::chrono::milliseconds(static_cast<int>(number(options, "--timeout-ms", 500)));
  // The fix's capture time is the instant the detector's view shows (the first field of an interlaced frame).
  const int64_t view_offset_us = view_time_offset_us(settings.locator.detector.deinterlace, settings.field_period_ms);
  const double status_period_s = number(options, "--status-s", 1.0);
  StereoStarLocator locator(calibration, settings.locator);
  std::signal(SIGINT, [](int) { g_stop = 1; });
  std::signal(SIGTERM, [](int) { g_stop = 1; });

  Station station(locator, *source, timeout);
  Status status, total;
  int64_t status_start = monotonic_us();
  bool stalled = false;
  cv::Mat shown;  // the last frame the window displayed
  while (!g_stop) {
    if (link) link->poll(monotonic_us());
    const StationStep step = station.step();
    if (step.status == ReadStatus::kEnd) break;
    if (step.status == ReadStatus::kNoFrame) {
      ++status.stalls;
      ++total.stalls;
      if (!stalled) std::cerr << "no fix: no frames for " << timeout.count() << " ms: " << source->health() << "\n";
      stalled = true;
    } else {
      if (stalled) std::cerr << "frames are back\n";
      stalled = false;
      status.add(step.fix);
      total.add(step.fix);
      if (step.fix.found && link) {
        link->send(step.fix, settings.mount, step.frame.capture_time_us + view_offset_us);
      }
      source->answered(step.fix.found, link ? link->frames_sent() : 0);
      if (display) shown = show(step.frame, step.fix);
    }
    const int64_t now = monotonic_us();
    if ((now - status_start) * 1e-6 >= status_period_s) {
      std::cerr << status.line((now - status_start) * 1e-6);
      if (const auto pairing = source->pairing_stats()) std::cerr << ", " << pairing_line(*pairing);
      if (link) {
        std::cerr << ", sent " << link->frames_sent() << " dropped " << link->frames_dropped()
                  << (link->synchronised() ? ", timesync offset " + std::to_string(link->offset_us()) + " us"
                                           : ", no TIMESYNC reply yet (station clock)");
      }
      std::cerr << "\n";
      status = Status{};
      status_start = now;
    }
  }
  std::cerr << "total: " << total.frames << " frames, " << total.fixes << " fixes\n";
  if (!stats_path.empty()) write_stats(stats_path, total, source->pairing_stats());
  if (!screenshot.empty()) {
    // Proof that the window was on screen, and the exact picture it showed last.
    if (shown.empty()) throw std::runtime_error("--show-screenshot: no frame was displayed");
    if (cv::getWindowProperty(kWindow, cv::WND_PROP_VISIBLE) <= 0) {
      throw std::runtime_error("--show-screenshot: the window is not visible");
    }
    if (!cv::imwrite(screenshot, shown)) throw std::runtime_error("--show-screenshot: cannot write " + screenshot);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << kUsage;
    return 2;
  }
  const std::string command = argv[1];
  try {
    if (command == "detect") return detect(parse_options(argc, argv, {}));
    if (command == "calibrate") return calibrate(parse_options(argc, argv, {}));
    if (command == "run") return run(parse_options(argc, argv, {"--show"}));
    if (command == "calibrate-room") return ground::calibrate_room_command(parse_options(argc, argv, {}));
    if (command == "track") return ground::track_command(parse_options(argc, argv, {"--no-epipolar", "--no-roi"}));
    if (command == "--help" || command == "-h") {
      std::cout << kUsage;
      return 0;
    }
    throw UsageError("unknown command '" + command + "'");
  } catch (const ground::CommandUsageError& e) {
    std::cerr << "vision_station: " << e.what() << "\n" << kUsage;
    return 2;
  } catch (const UsageError& e) {
    std::cerr << "vision_station: " << e.what() << "\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "vision_station " << command << ": " << e.what() << "\n";
    return 1;
  }
}
