// One cycle of the live station: wait for the next stereo pair (at most a timeout), locate the star.
// A source that stops delivering gives "no fix" (never the last position) and the tracker forgets its
// region of interest; when frames return, the next pair is searched in full.
#pragma once

#include <chrono>

#include "quad/vision/frame_source.h"
#include "quad/vision/stereo_locator.h"

namespace quad::vision {

struct StationStep {
  ReadStatus status = ReadStatus::kNoFrame;
  StereoFrame frame;  // valid when status == kFrame
  StarFix fix;        // found only for a fresh frame in which the star was located
};

class Station {
 public:
  Station(StereoStarLocator& locator, FrameSource& source, std::chrono::milliseconds timeout)
      : locator_(locator), source_(source), timeout_(timeout) {}

  // Throws std::runtime_error when a frame does not match the calibrated image size.
  StationStep step();

 private:
  StereoStarLocator& locator_;
  FrameSource& source_;
  std::chrono::milliseconds timeout_;
};

}  // namespace quad::vision
