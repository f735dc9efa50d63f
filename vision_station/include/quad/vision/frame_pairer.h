// Two cameras are two clocks: each delivers frames stamped with its own capture time, at its own rate,
// and drops its own frames. FramePairer pairs left and right by nearest capture time and refuses a pair
// whose skew exceeds a limit (by default half the frame period: beyond it, the other camera's previous
// or next frame would be at least as close, so the images are not of one instant).
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace quad::vision {

struct TimedFrame {
  cv::Mat image;
  int64_t time_us = 0;  // the capture time on the camera's clock (both on one time base)
};

struct PairingStats {
  uint64_t pairs = 0;
  uint64_t unpaired[2] = {0, 0};  // frames discarded without a partner (left, right)
  uint64_t refused[2] = {0, 0};   // ... of which the nearest partner was further than the limit
  uint64_t missing[2] = {0, 0};   // frames absent from a camera's own sequence (gaps of > 1.5 periods)
  double period_us[2] = {0, 0};   // median frame interval of each camera
  double max_skew_us = 0.0;       // the limit in use
  std::vector<double> skews_us;   // |left − right| of every pair
  double mean_skew_us() const;
  double max_observed_skew_us() const;
  double percentile_skew_us(double p) const;
  // One JSON object with the counters and skew statistics in milliseconds.
  std::string json() const;
};

class FramePairer {
 public:
  // max_skew_us <= 0: half the shorter of the two measured frame periods (33.3 ms assumed until known).
  explicit FramePairer(double max_skew_us = 0.0, size_t max_queue = 16);

  // Frames of one camera must come in time order.
  void push(int camera, TimedFrame frame);
  // The next pair (left, right), or nothing until more frames arrive. With `flush` (the streams have
  // ended) it decides without waiting for a camera's next frame.
  std::optional<std::pair<TimedFrame, TimedFrame>> pop(bool flush = false);

  const PairingStats& stats() const { return stats_; }
  double max_skew_us() const;
  size_t queued(int camera) const { return queue_[camera].size(); }

 private:
  void drop_front(int camera, bool refused);
  double period_us(int camera) const;

  double configured_max_skew_us_;
  size_t max_queue_;
  std::deque<TimedFrame> queue_[2];
  std::vector<double> intervals_[2];  // recent frame intervals, for the period
  int64_t last_time_us_[2] = {0, 0};
  bool seen_[2] = {false, false};
  PairingStats stats_;
};

}  // namespace quad::vision
