// The pace of a run's progress line on stderr (rewritten in place with \r): at most one line every
// 250 ms of wall time, so that printing costs a fast run nothing, and always the final one.
#pragma once

#include <chrono>

namespace quad::sim {

class ProgressPace {
 public:
  using Clock = std::chrono::steady_clock;

  // Whether a line is due at `now`; a due line counts as printed.
  bool due(Clock::time_point now, bool final_line) {
    if (!final_line && now - last_ < std::chrono::milliseconds(250)) return false;
    last_ = now;
    return true;
  }

 private:
  Clock::time_point last_{};
};

}  // namespace quad::sim
