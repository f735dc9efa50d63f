#include "quad/vision/frame_source.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <thread>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "quad/vision/frame_pairer.h"
#include "quad/vision/pair_list.h"
#include "quad/vision/sim_source.h"

namespace quad::vision {

int64_t monotonic_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

namespace {

namespace fs = std::filesystem;

// files:DIR — pairs.csv when present, else left*/right* files matched by the rest of their names.
class FilesSource : public FrameSource {
 public:
  explicit FilesSource(const std::string& dir) {
    if (!fs::is_directory(dir)) throw FrameSourceError("files:" + dir + ": not a directory");
    const fs::path csv = fs::path(dir) / "pairs.csv";
    if (fs::exists(csv)) {
      pairs_ = read_pair_list(csv.string());
    } else {
      std::vector<fs::path> lefts;
      for (const auto& entry : fs::directory_iterator(dir)) {
        const std::string name = entry.path().filename().string();
        if (entry.is_regular_file() && name.rfind("left", 0) == 0) lefts.push_back(entry.path());
      }
      std::sort(lefts.begin(), lefts.end());
      for (const fs::path& left : lefts) {
        const fs::path right = left.parent_path() / ("right" + left.filename().string().substr(4));
        if (fs::exists(right)) pairs_.push_back(ImagePair{left.string(), right.string(), 0});
      }
    }
    if (pairs_.empty()) {
      throw FrameSourceError("files:" + dir + ": no image pairs (need pairs.csv or leftNAME/rightNAME files)");
    }
  }

  ReadStatus read(StereoFrame& frame, std::chrono::milliseconds) override {
    if (next_ >= pairs_.size()) return ReadStatus::kEnd;
    const ImagePair& pair = pairs_[next_++];
    frame.left = read_grey_image(pair.left);
    frame.right = read_grey_image(pair.right);
    frame.capture_time_us = monotonic_us();
    frame.sequence = next_;
    frame.label = pair.left + "," + pair.right;
    return ReadStatus::kFrame;
  }

 private:
  std::vector<ImagePair> pairs_;
  size_t next_ = 0;
};

cv::Mat to_grey(const cv::Mat& image) {
  cv::Mat out;
  if (image.channels() == 1) {
    out = image.clone();
  } else {
    cv::cvtColor(image, out, cv::COLOR_BGR2GRAY);  // thesis step 1: greyscale
  }
  return out;
}

// Two cv::VideoCapture streams (v4l2 devices or video files), each with its own clock: every frame is
// stamped with its capture time and a FramePairer pairs left and right by nearest time, refusing pairs
// further apart than the skew limit. Live devices: one thread per camera, stamped with the driver's
// buffer time (CAP_PROP_POS_MSEC, CLOCK_MONOTONIC in OpenCV's V4L2 backend) or the grab time, the
// newest pair kept; a failing device is reopened every half second. Video files: one thread reads the
// stream that is behind, stamps each frame with its presentation time (CAP_PROP_POS_MSEC) plus the
// file's start offset, and hands over every pair in order. read() waits at most its timeout, so a
// stalled camera yields kNoFrame instead of blocking the station.
class CaptureSource : public FrameSource {
 public:
  CaptureSource(std::array<std::string, 2> paths, std::array<double, 2> offsets_ms, bool live, double max_skew_us)
      : paths_(std::move(paths)), offsets_us_{offsets_ms[0] * 1e3, offsets_ms[1] * 1e3}, live_(live),
        pairer_(max_skew_us), start_us_(monotonic_us()) {
    for (int i = 0; i < 2; ++i) open(i);
    if (!live_) {
      for (int i = 0; i < 2; ++i) {
        if (!captures_[i].isOpened()) throw FrameSourceError("video: cannot open '" + paths_[i] + "'");
      }
      workers_.emplace_back([this] { file_loop(); });
    } else {
      for (int i = 0; i < 2; ++i) workers_.emplace_back([this, i] { camera_loop(i); });
    }
  }
  ~CaptureSource() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    for (std::thread& worker : workers_) worker.join();
  }

  ReadStatus read(StereoFrame& frame, std::chrono::milliseconds timeout) override {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!cv_.wait_for(lock, timeout, [this] { return fresh_ || ended_; })) return ReadStatus::kNoFrame;
    if (!fresh_) return ReadStatus::kEnd;
    frame = std::move(latest_);
    fresh_ = false;
    cv_.notify_all();
    return ReadStatus::kFrame;
  }

  std::string health() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    std::string out;
    for (const std::string& p : problem_) out += (out.empty() || p.empty() ? "" : "; ") + p;
    return out;
  }

  std::optional<PairingStats> pairing_stats() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return pairer_.stats();
  }

 private:
  void open(int i) {
    captures_[i].release();
    if (live_) {
      captures_[i].open(paths_[i], cv::CAP_V4L2);
    } else {
      // FFmpeg reads every common container and reports each frame's presentation time, gaps included
      // (OpenCV's own MJPEG reader counts frames instead).
      captures_[i].open(paths_[i], cv::CAP_FFMPEG);
    }
  }

  // Under the lock: hands over the pairs the pairer has. Files wait until the last one was taken; live
  // cameras keep only the newest.
  void deliver_pairs(std::unique_lock<std::mutex>& lock, bool flush) {
    while (auto pair = pairer_.pop(flush)) {
      if (!live_) cv_.wait(lock, [this] { return !fresh_ || stop_; });
      if (stop_) return;
      StereoFrame frame;
      frame.left = std::move(pair->first.image);
      frame.right = std::move(pair->second.image);
      frame.skew_us = pair->second.time_us - pair->first.time_us;
      // The pair's capture time: the middle of its two exposures, on the station clock.
      const int64_t middle = (pair->first.time_us + pair->second.time_us) / 2;
      frame.capture_time_us = live_ ? middle : start_us_ + middle;
      frame.sequence = ++sequence_;
      frame.label = live_ ? "" : paths_[0] + "@" + std::to_string(pair->first.time_us / 1000.0) + "ms," + paths_[1] +
                                     "@" + std::to_string(pair->second.time_us / 1000.0) + "ms";
      latest_ = std::move(frame);
      fresh_ = true;
      cv_.notify_all();
    }
  }

  void camera_loop(int i) {
    cv::Mat image;
    while (!stop_) {
      if (!captures_[i].isOpened() || !captures_[i].grab()) {
        set_problem(i, std::string(i == 0 ? "left" : "right") + " camera " + paths_[i] +
                           (captures_[i].isOpened() ? " stopped delivering frames" : " cannot be opened") +
                           "; retrying");
        std::this_thread::sleep_for(std::chrono::milliseconds(500));
        open(i);
        continue;
      }
      int64_t t = monotonic_us();
      const double driver_ms = captures_[i].get(cv::CAP_PROP_POS_MSEC);
      if (driver_ms > 0.0 && std::fabs(driver_ms * 1e3 - static_cast<double>(t)) < 2e6) {
        t = static_cast<int64_t>(driver_ms * 1e3);
      }
      if (!captures_[i].retrieve(image)) continue;
      set_problem(i, "");
      std::unique_lock<std::mutex> lock(mutex_);
      pairer_.push(i, TimedFrame{to_grey(image), t});
      deliver_pairs(lock, false);
    }
  }

  void file_loop() {
    cv::Mat image;
    bool ended[2] = {false, false};
    int64_t last[2] = {std::numeric_limits<int64_t>::min(), std::numeric_limits<int64_t>::min()};
    while (!stop_) {
      // Read the stream that is behind, so that both queues stay short.
      const int i = ended[0] ? 1 : ended[1] ? 0 : (last[0] <= last[1] ? 0 : 1);
      if (ended[0] && ended[1]) break;
      if (!captures_[i].grab() || !captures_[i].retrieve(image)) {
        ended[i] = true;
        continue;
      }
      last[i] = static_cast<int64_t>(captures_[i].get(cv::CAP_PROP_POS_MSEC) * 1e3 + offsets_us_[i]);
      std::unique_lock<std::mutex> lock(mutex_);
      pairer_.push(i, TimedFrame{to_grey(image), last[i]});
      deliver_pairs(lock, false);
    }
    std::unique_lock<std::mutex> lock(mutex_);
    deliver_pairs(lock, true);
    if (!stop_) cv_.wait(lock, [this] { return !fresh_ || stop_; });
    ended_ = true;
    cv_.notify_all();
  }

  void set_problem(int i, std::string problem) {
    std::lock_guard<std::mutex> lock(mutex_);
    problem_[i] = std::move(problem);
  }

  std::array<std::string, 2> paths_;
  double offsets_us_[2];
  bool live_;
  cv::VideoCapture captures_[2];
  std::vector<std::thread> workers_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  FramePairer pairer_;
  int64_t start_us_;
  uint64_t sequence_ = 0;
  StereoFrame latest_;
  bool fresh_ = false;
  bool ended_ = false;
  std::string problem_[2];
};

// "PATH@MS": a video file whose first frame was captured MS milliseconds after the common time origin.
std::pair<std::string, double> path_and_offset(const std::string& text) {
  const size_t at = text.rfind('@');
  if (at != std::string::npos && at + 1 < text.size()) {
    try {
      size_t used = 0;
      const double ms = std::stod(text.substr(at + 1), &used);
      if (used == text.size() - at - 1 && std::isfinite(ms)) return {text.substr(0, at), ms};
    } catch (const std::exception&) {
    }
  }
  return {text, 0.0};
}

std::pair<std::string, std::string> split_pair(const std::string& spec, const std::string& rest) {
  const size_t comma = rest.find(',');
  if (comma == std::string::npos || comma == 0 || comma + 1 == rest.size()) {
    throw FrameSourceError("source '" + spec + "': expected two paths separated by a comma");
  }
  return {rest.substr(0, comma), rest.substr(comma + 1)};
}

}  // namespace

std::unique_ptr<FrameSource> make_frame_source(const std::string& spec, double max_skew_us) {
  const size_t colon = spec.find(':');
  const std::string scheme = colon == std::string::npos ? "" : spec.substr(0, colon);
  const std::string rest = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (scheme == "files") return std::make_unique<FilesSource>(rest);
  if (scheme == "v4l2") {
    auto [left, right] = split_pair(spec, rest);
    return std::make_unique<CaptureSource>(std::array<std::string, 2>{left, right}, std::array<double, 2>{0.0, 0.0},
                                           true, max_skew_us);
  }
  if (scheme == "video") {
    auto [left, right] = split_pair(spec, rest);
    const auto [left_path, left_ms] = path_and_offset(left);
    const auto [right_path, right_ms] = path_and_offset(right);
    return std::make_unique<CaptureSource>(std::array<std::string, 2>{left_path, right_path},
                                           std::array<double, 2>{left_ms, right_ms}, false, max_skew_us);
  }
  if (scheme == "sim") {
    if (rest.empty()) throw FrameSourceError("source '" + spec + "': needs the simulator's socket path, sim:PATH");
    return make_sim_source(rest);
  }
  throw FrameSourceError("source '" + spec + "': unknown kind (use files:DIR, v4l2:/dev/A,/dev/B, video:L,R, sim:PATH)");
}

}  // namespace quad::vision
