// MAVLink frames held back until their release time (a simulated sensor's latency to the radio), then
// handed out in the order they were queued: the output side of the simulated fix and pose feeds.
#pragma once

#include <cstdint>
#include <deque>
#include <utility>
#include <vector>

#include "quad/link/mavlink.h"

namespace quad::sim {

class DelayedFrames {
 public:
  // Hands sink(release_time, const uint8_t*, size_t) every frame whose release time is <= t, in order.
  template <class Sink>
  void release_until(double t, Sink&& sink) {
    while (!pending_.empty() && pending_.front().first <= t + 1e-9) {
      const auto& [when, bytes] = pending_.front();
      sink(when, bytes.data(), bytes.size());
      ++released_;
      pending_.pop_front();
    }
  }

  uint64_t released() const { return released_; }

 protected:
  DelayedFrames(uint8_t system_id, uint8_t component_id) : sender_(system_id, component_id) {}

  // Encodes msg now (the sequence numbers follow the order of queueing) for release at release_t.
  template <class Msg>
  void queue(double release_t, const Msg& msg) {
    uint8_t buf[mavlink::max_frame_length<Msg>()];
    const size_t n = sender_.encode(msg, buf, sizeof buf);
    pending_.emplace_back(release_t, std::vector<uint8_t>(buf, buf + n));
  }

 private:
  mavlink::Sender sender_;
  std::deque<std::pair<double, std::vector<uint8_t>>> pending_;  // release time, frame
  uint64_t released_ = 0;
};

}  // namespace quad::sim
