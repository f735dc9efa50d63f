// Two cameras, two clocks: pairing by nearest capture time with a skew limit, checked against a brute
// force oracle (every mutually nearest left/right pair within the limit, and nothing else), then end to
// end on two recorded interlaced MJPEG AVI files (cv::VideoWriter, MJPG) whose clocks are offset and
// which drop different frames (removed with ffmpeg, which writes AVI's empty "dropped frame" chunks).
// Each frame carries its true capture time as a printed block code, so what the source pairs is checked
// on the images themselves.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "quad/vision/frame_pairer.h"
#include "quad/vision/frame_source.h"
#include "quad/vision/stereo_calibration.h"

namespace quad::vision {
namespace {

namespace fs = std::filesystem;

struct Timeline {
  double period_ms, offset_ms;
  int count;
  std::set<int> dropped;
  std::vector<int64_t> times_us() const {
    std::vector<int64_t> t;
    for (int k = 0; k < count; ++k) {
      if (!dropped.count(k)) t.push_back(static_cast<int64_t>(std::llround((offset_ms + k * period_ms) * 1e3)));
    }
    return t;
  }
};

using PairSet = std::set<std::pair<int64_t, int64_t>>;

// The oracle: (l, r) is a pair when r is the right frame nearest to l, l the left frame nearest to r,
// and they are at most `limit` apart.
PairSet mutual_nearest(const std::vector<int64_t>& left, const std::vector<int64_t>& right, double limit_us) {
  auto nearest = [](int64_t t, const std::vector<int64_t>& others) {
    int64_t best = others.front();
    for (int64_t o : others) {
      if (std::llabs(o - t) < std::llabs(best - t)) best = o;
    }
    return best;
  };
  PairSet out;
  for (int64_t l : left) {
    const int64_t r = nearest(l, right);
    if (nearest(r, left) == l && static_cast<double>(std::llabs(r - l)) <= limit_us) out.insert({l, r});
  }
  return out;
}

PairSet run_pairer(const Timeline& left, const Timeline& right, double limit_us, PairingStats* stats = nullptr) {
  FramePairer pairer(limit_us);
  const std::vector<int64_t> l = left.times_us(), r = right.times_us();
  PairSet out;
  size_t i = 0, j = 0;
  // Frames arrive in capture order across both cameras.
  while (i < l.size() || j < r.size()) {
    if (j >= r.size() || (i < l.size() && l[i] <= r[j])) {
      pairer.push(0, TimedFrame{cv::Mat(), l[i++]});
    } else {
      pairer.push(1, TimedFrame{cv::Mat(), r[j++]});
    }
    while (auto p = pairer.pop()) out.insert({p->first.time_us, p->second.time_us});
  }
  while (auto p = pairer.pop(true)) out.insert({p->first.time_us, p->second.time_us});
  if (stats) *stats = pairer.stats();
  return out;
}

constexpr double kPeriod = 1000.0 / 30.0;

TEST(FramePairer, OffsetClocksAndDifferentDropsGiveTheMutuallyNearestPairs) {
  const Timeline left{kPeriod, 0.0, 60, {7, 8, 31}}, right{kPeriod, 9.0, 60, {15, 40, 41}};
  PairingStats stats;
  const PairSet pairs = run_pairer(left, right, 0.0, &stats);
  EXPECT_NEAR(stats.max_skew_us, 0.5 * kPeriod * 1e3, 1.0);  // the default: half the frame period
  EXPECT_EQ(pairs, mutual_nearest(left.times_us(), right.times_us(), stats.max_skew_us));
  EXPECT_EQ(pairs.size(), 54u);
  EXPECT_EQ(stats.pairs, 54u);
  EXPECT_EQ(stats.missing[0], 3u);
  EXPECT_EQ(stats.missing[1], 3u);
  EXPECT_EQ(stats.unpaired[0], 3u);  // the partners of the right camera's dropped frames
  EXPECT_EQ(stats.unpaired[1], 3u);
  EXPECT_NEAR(stats.max_observed_skew_us(), 9000.0, 1.0);
}

TEST(FramePairer, PairsByTimeNotByIndex) {
  // The right camera 20 ms late: its frame k is nearest to the left frame k+1 (13.3 ms).
  const Timeline left{kPeriod, 0.0, 40, {}}, right{kPeriod, 20.0, 40, {}};
  PairingStats stats;
  const PairSet pairs = run_pairer(left, right, 0.0, &stats);
  EXPECT_EQ(pairs, mutual_nearest(left.times_us(), right.times_us(), stats.max_skew_us));
  EXPECT_EQ(pairs.size(), 39u);
  for (const auto& [l, r] : pairs) EXPECT_NEAR(static_cast<double>(l - r), 13333.0, 2.0);
}

TEST(FramePairer, RefusesPairsBeyondTheLimitAndHandlesDifferentRates) {
  const Timeline left{kPeriod, 0.0, 40, {}}, right{kPeriod, 9.0, 40, {}};
  PairingStats stats;
  EXPECT_TRUE(run_pairer(left, right, 5000.0, &stats).empty());
  EXPECT_EQ(stats.refused[0], 40u);
  // 30 fps against 25 fps, drops on both sides, a 3 ms limit and the default.
  const Timeline fast{kPeriod, 4.0, 90, {10, 11, 12, 50}}, slow{40.0, 0.0, 75, {3, 30, 31}};
  for (double limit : {3000.0, 0.0}) {
    const PairSet pairs = run_pairer(fast, slow, limit, &stats);
    EXPECT_EQ(pairs, mutual_nearest(fast.times_us(), slow.times_us(), stats.max_skew_us)) << "limit " << limit;
    EXPECT_GT(pairs.size(), 10u);
  }
}

// --- recorded video files -------------------------------------------------------------------------

const cv::Size kSize(728, 488);  // the thesis rig's image size, so that the station can run on the files
constexpr int kBits = 14;

// The frame's capture time (ms) as a row of black/white blocks, in both fields.
void print_time(cv::Mat& frame, int ms) {
  for (int b = 0; b < kBits; ++b) {
    const cv::Scalar colour = ((ms >> b) & 1) ? cv::Scalar(255, 255, 255) : cv::Scalar(0, 0, 0);
    cv::rectangle(frame, cv::Rect(20 + 48 * b, 20, 40, 40), colour, cv::FILLED);
  }
}

int read_time(const cv::Mat& grey) {
  int ms = 0;
  for (int b = 0; b < kBits; ++b) {
    if (cv::mean(grey(cv::Rect(28 + 48 * b, 28, 24, 24)))[0] > 128.0) ms |= 1 << b;
  }
  return ms;
}

// An interlaced analog frame: even rows (first field) at t, odd rows at t + 1/60 s, a bar moving at
// 600 px/s so that the two fields differ.
cv::Mat interlaced_frame(double t_ms) {
  cv::Mat fields[2];
  for (int f = 0; f < 2; ++f) {
    fields[f] = cv::Mat(kSize, CV_8UC3, cv::Scalar(170, 170, 170));
    const int x = static_cast<int>(100 + 0.6 * (t_ms + f * 1000.0 / 60.0)) % (kSize.width - 40);
    cv::rectangle(fields[f], cv::Rect(x, 120, 30, 300), cv::Scalar(40, 40, 40), cv::FILLED);
  }
  cv::Mat frame = fields[0].clone();
  for (int y = 1; y < kSize.height; y += 2) fields[1].row(y).copyTo(frame.row(y));
  return frame;
}

bool have_ffmpeg() { return std::system("ffmpeg -version > /dev/null 2>&1") == 0; }

// Writes the camera's frames (each printed with its time on the common clock; the file's own clock
// starts at its first frame) with cv::VideoWriter (MJPG), then drops `dropped` with ffmpeg
// (-c copy: the JPEG data is untouched; the AVI keeps the gaps as empty chunks, so the dropped frames'
// times are missing from the file's timeline).
void record(const fs::path& path, const Timeline& camera, const fs::path& scratch) {
  const fs::path full = scratch / ("full_" + path.filename().string());
  {
    cv::VideoWriter writer(full.string(), cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                           1000.0 / camera.period_ms, kSize, true);
    ASSERT_TRUE(writer.isOpened());
    for (int k = 0; k < camera.count; ++k) {
      const double t = camera.offset_ms + k * camera.period_ms;
      cv::Mat frame = interlaced_frame(t);
      print_time(frame, static_cast<int>(std::lround(t)));
      writer.write(frame);
    }
  }
  std::string drop;
  for (int k : camera.dropped) drop += (drop.empty() ? "" : "+") + std::string("eq(n\\,") + std::to_string(k) + ")";
  const std::string command = "ffmpeg -loglevel error -y -i '" + full.string() + "' -c copy -bsf:v 'noise=drop=" + drop +
                              "' -fps_mode passthrough '" + path.string() + "'";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
}

class RecordedPair : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg is not installed (tools/packages-debian.txt)";
    dir_ = fs::temp_directory_path() / ("quad_pairing_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // The right capture started 9 ms after the left (given as @9 on its path); 30 fps both.
    record(dir_ / "left.avi", left_, dir_);
    record(dir_ / "right.avi", right_, dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  std::string spec() const {
    return "video:" + (dir_ / "left.avi").string() + "," + (dir_ / "right.avi").string() + "@9";
  }

  const double period_ = 1000.0 / 30.0;
  const Timeline left_{period_, 0.0, 60, {7, 8, 31}};
  const Timeline right_{period_, 9.0, 60, {15, 40, 41}};
  fs::path dir_;
};

TEST_F(RecordedPair, VideoSourcePairsTheInterlacedMjpegFilesByCaptureTime) {
  const std::unique_ptr<FrameSource> source = make_frame_source(spec());
  PairSet seen;
  StereoFrame frame;
  int64_t last_capture = 0;
  while (source->read(frame, std::chrono::milliseconds(5000)) == ReadStatus::kFrame) {
    // The printed times are rounded to 1 ms: compare in ms.
    const int l = read_time(frame.left), r = read_time(frame.right);
    EXPECT_NEAR(frame.skew_us / 1000.0, r - l, 1.0);
    EXPECT_GT(frame.capture_time_us, last_capture);
    last_capture = frame.capture_time_us;
    seen.insert({l, r});
  }
  const auto stats = source->pairing_stats();
  ASSERT_TRUE(stats.has_value());
  PairSet expected;
  for (const auto& [l, r] : mutual_nearest(left_.times_us(), right_.times_us(), stats->max_skew_us)) {
    expected.insert({static_cast<int64_t>(std::lround(l / 1000.0)), static_cast<int64_t>(std::lround(r / 1000.0))});
  }
  EXPECT_EQ(seen, expected);
  EXPECT_EQ(seen.size(), 54u);
  EXPECT_EQ(stats->missing[0], 3u);
  EXPECT_EQ(stats->missing[1], 3u);
  EXPECT_EQ(stats->unpaired[0], 3u);
  EXPECT_EQ(stats->unpaired[1], 3u);
  EXPECT_NEAR(stats->max_observed_skew_us(), 9000.0, 1000.0);
  std::printf("[vision] recorded pair: %s\n", stats->json().c_str());
}

TEST_F(RecordedPair, RunWritesSkewAndDroppedFramesToStats) {
  save_calibration(rectify(thesis_stereo_rig()), (dir_ / "calib.yaml").string());
  const fs::path stats = dir_ / "stats.json", log = dir_ / "log.txt";
  const std::string command = std::string(VISION_STATION_EXE) + " run --calib '" + (dir_ / "calib.yaml").string() +
                              "' --source '" + spec() + "' --status-s 0 --stats '" + stats.string() + "' 2> '" +
                              log.string() + "'";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  std::ifstream in(stats);
  std::stringstream text;
  text << in.rdbuf();
  const std::string json = text.str();
  std::printf("[vision] vision_station run --stats: %s", json.c_str());
  EXPECT_NE(json.find("\"frames\":54"), std::string::npos) << json;
  EXPECT_NE(json.find("\"pairs\":54"), std::string::npos) << json;
  EXPECT_NE(json.find("\"missing\":{\"left\":3,\"right\":3}"), std::string::npos) << json;
  EXPECT_NE(json.find("\"unpaired\":{\"left\":3,\"right\":3}"), std::string::npos) << json;
  std::ifstream log_in(log);
  std::stringstream log_text;
  log_text << log_in.rdbuf();
  EXPECT_NE(log_text.str().find("skew ms mean"), std::string::npos) << log_text.str();
  EXPECT_NE(log_text.str().find("missing L"), std::string::npos) << log_text.str();

  // The limit as a setting: 5 ms refuses every pair of clocks 9 ms apart.
  {
    std::ofstream settings(dir_ / "settings.yaml");
    settings << "%YAML:1.0\nmax_pair_skew_ms: 5\n";
  }
  const std::string strict = std::string(VISION_STATION_EXE) + " run --calib '" + (dir_ / "calib.yaml").string() +
                             "' --source '" + spec() + "' --settings '" + (dir_ / "settings.yaml").string() +
                             "' --stats '" + stats.string() + "' 2> /dev/null";
  ASSERT_EQ(std::system(strict.c_str()), 0) << strict;
  std::ifstream strict_in(stats);
  const std::string strict_json((std::istreambuf_iterator<char>(strict_in)), std::istreambuf_iterator<char>());
  EXPECT_NE(strict_json.find("\"pairs\":0,"), std::string::npos) << strict_json;
  EXPECT_NE(strict_json.find("\"limit\":5.000"), std::string::npos) << strict_json;
}

}  // namespace
}  // namespace quad::vision
