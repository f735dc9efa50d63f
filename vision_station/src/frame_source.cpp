#include "quad/vision/frame_source.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <thread>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

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

// Two cv::VideoCapture streams (v4l2 devices or video files). A thread grabs both (grab() close together,
// then retrieve(), to keep the pair in step) and hands the newest pair over; read() waits at most the
// timeout, so a stalled camera yields kNoFrame instead of blocking the station. Live devices that fail
// are reopened every half second; video files deliver every pair in order.
class CaptureSource : public FrameSource {
 public:
  CaptureSource(std::string left, std::string right, bool live)
      : paths_{std::move(left), std::move(right)}, live_(live) {
    open();
    if (!live_ && (!captures_[0].isOpened() || !captures_[1].isOpened())) {
      throw FrameSourceError("video: cannot open '" + paths_[captures_[0].isOpened() ? 1 : 0] + "'");
    }
    worker_ = std::thread([this] { loop(); });
  }
  ~CaptureSource() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    cv_.notify_all();
    worker_.join();
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
    return problem_;
  }

 private:
  void open() {
    for (int i = 0; i < 2; ++i) {
      captures_[i].release();
      if (live_) {
        captures_[i].open(paths_[i], cv::CAP_V4L2);
      } else {
        // FFmpeg reads every common container; OpenCV's own MJPEG reader covers the rest without
        // probing camera backends.
        if (!captures_[i].open(paths_[i], cv::CAP_FFMPEG)) captures_[i].open(paths_[i], cv::CAP_OPENCV_MJPEG);
      }
    }
  }

  void set_problem(std::string problem) {
    std::lock_guard<std::mutex> lock(mutex_);
    problem_ = std::move(problem);
  }

  void loop() {
    cv::Mat images[2];
    uint64_t sequence = 0;
    while (!stop_) {
      const bool opened = captures_[0].isOpened() && captures_[1].isOpened();
      const bool grabbed = opened && captures_[0].grab() && captures_[1].grab();
      const int64_t t = monotonic_us();
      if (!grabbed || !captures_[0].retrieve(images[0]) || !captures_[1].retrieve(images[1])) {
        if (!live_) {
          std::lock_guard<std::mutex> lock(mutex_);
          ended_ = true;
          cv_.notify_all();
          return;
        }
        set_problem(std::string(opened ? "a camera stopped delivering frames" : "cannot open the cameras") + " (" +
                    paths_[0] + ", " + paths_[1] + "); retrying");
        std::this_thread::sleep_for(std::chrono::milliseconds(500));
        open();
        continue;
      }
      StereoFrame frame;
      for (int i = 0; i < 2; ++i) {
        cv::Mat& out = i == 0 ? frame.left : frame.right;
        if (images[i].channels() == 1) {
          out = images[i].clone();
        } else {
          cv::cvtColor(images[i], out, cv::COLOR_BGR2GRAY);  // thesis step 1: greyscale
        }
      }
      frame.capture_time_us = t;
      frame.sequence = ++sequence;
      std::unique_lock<std::mutex> lock(mutex_);
      // Files deliver every pair (wait until the last one was taken); live cameras keep only the newest.
      if (!live_) cv_.wait(lock, [this] { return !fresh_ || stop_; });
      latest_ = std::move(frame);
      fresh_ = true;
      problem_.clear();
      cv_.notify_all();
    }
  }

  std::string paths_[2];
  bool live_;
  cv::VideoCapture captures_[2];
  std::thread worker_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  StereoFrame latest_;
  bool fresh_ = false;
  bool ended_ = false;
  std::string problem_;
};

std::pair<std::string, std::string> split_pair(const std::string& spec, const std::string& rest) {
  const size_t comma = rest.find(',');
  if (comma == std::string::npos || comma == 0 || comma + 1 == rest.size()) {
    throw FrameSourceError("source '" + spec + "': expected two paths separated by a comma");
  }
  return {rest.substr(0, comma), rest.substr(comma + 1)};
}

}  // namespace

std::unique_ptr<FrameSource> make_frame_source(const std::string& spec) {
  const size_t colon = spec.find(':');
  const std::string scheme = colon == std::string::npos ? "" : spec.substr(0, colon);
  const std::string rest = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (scheme == "files") return std::make_unique<FilesSource>(rest);
  if (scheme == "v4l2") {
    auto [left, right] = split_pair(spec, rest);
    return std::make_unique<CaptureSource>(left, right, true);
  }
  if (scheme == "video") {
    auto [left, right] = split_pair(spec, rest);
    return std::make_unique<CaptureSource>(left, right, false);
  }
  if (scheme == "sim") {
    if (rest.empty()) throw FrameSourceError("source '" + spec + "': needs the simulator's socket path, sim:PATH");
    return make_sim_source(rest);
  }
  throw FrameSourceError("source '" + spec + "': unknown kind (use files:DIR, v4l2:/dev/A,/dev/B, video:L,R, sim:PATH)");
}

}  // namespace quad::vision
