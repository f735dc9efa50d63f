// Where stereo frame pairs come from. Each source is one class behind FrameSource; `make_frame_source`
// parses the command-line spec:
//   files:DIR                  image pairs in DIR (pairs.csv with columns left,right, or left*/right* names)
//   v4l2:/dev/videoA,/dev/videoB  two capture devices
//   video:LEFT.avi[@MS],RIGHT.avi[@MS]  two video files; @MS: the time of the file's first frame on a
//                              common clock (default 0), for recordings that started apart
//   sim:ENDPOINT               the simulator's rendered cameras, lockstep over a Unix socket (sim_source.h)
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

#include <optional>

#include <opencv2/core.hpp>

#include "quad/vision/frame_pairer.h"

namespace quad::vision {

struct StereoFrame {
  cv::Mat left, right;          // CV_8UC1
  int64_t capture_time_us = 0;  // station monotonic clock (steady_clock), or the source's own clock;
                                // for two clocked cameras the middle of the pair's two capture times
  int64_t skew_us = 0;          // right − left capture time (sources that stamp each camera)
  uint64_t sequence = 0;
  std::string label;            // e.g. the file names, for messages
};

enum class ReadStatus {
  kFrame,    // a new pair
  kNoFrame,  // nothing new within the timeout (camera stalled): the caller reports "no fix"
  kEnd,      // finite source exhausted
};

struct FrameSourceError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  virtual ReadStatus read(StereoFrame& frame, std::chrono::milliseconds timeout) = 0;
  // One line for the status output when something is wrong (e.g. "left camera: no frames for 2.1 s").
  virtual std::string health() const { return {}; }
  // Called once the station has processed `frame`, with its processing time: a lockstep source (the
  // simulator's) accounts it in simulated time before releasing the next frame.
  virtual void processed(const StereoFrame& /*frame*/, double /*processing_us*/) {}
  // Called once the station's output for the last processed frame has been written (a fix on the radio
  // port, or nothing): a lockstep source tells its simulator it may collect that output now.
  virtual void answered(bool /*fix_found*/, uint64_t /*fixes_sent_total*/) {}
  // True when capture_time_us is already on the vehicle's clock (the simulator's): no TIMESYNC needed.
  virtual bool vehicle_clock() const { return false; }
  // Pairing of two independently clocked cameras (v4l2, video): skews, unpaired and missing frames.
  virtual std::optional<PairingStats> pairing_stats() const { return std::nullopt; }
};

// Throws FrameSourceError with a message naming the problem (unknown scheme, missing files...).
// max_skew_us: the pairing limit of two-camera sources (<= 0: half the measured frame period).
std::unique_ptr<FrameSource> make_frame_source(const std::string& spec, double max_skew_us = 0.0);

int64_t monotonic_us();

}  // namespace quad::vision
