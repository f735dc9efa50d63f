// One direction of an emulated serial line, in simulated time: frames are paced to the baud rate (8N1,
// 10 bit times a byte) and, on a radio line, pass through the radio model first: loss of whole frames,
// random bit errors, latency and jitter (an XBee keeps the order of its packets).
//
// The line never touches a file descriptor: it only decides which bytes arrive when. The simulator
// writes what deliver_until() hands it to the pseudo-terminal (pty.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

#include "quad/sim/rng.h"

namespace quad::sim {

struct RadioConditions {
  double latency_s = 0.0;        // fixed part of the delay through the radios
  double jitter_s = 0.0;         // extra delay, uniform in [0, jitter_s]
  double loss = 0.0;             // probability a frame is lost
  double bit_error_rate = 0.0;   // probability each delivered bit is flipped
};

struct LineStats {
  uint64_t frames_sent = 0;
  uint64_t frames_lost = 0;
  uint64_t frames_corrupted = 0;  // delivered with at least one flipped bit
  uint64_t bits_flipped = 0;
  uint64_t bytes_sent = 0;
  uint64_t bytes_delivered = 0;
};

class SerialLine {
 public:
  SerialLine(double baud, Rng rng) : byte_time_s_(10.0 / baud), rng_(std::move(rng)) {}

  void set_radio(const RadioConditions& radio) { radio_ = radio; }
  const RadioConditions& radio() const { return radio_; }

  // Hands one frame to the line at simulated time t.
  void send(const uint8_t* data, size_t length, double t);

  // Calls sink(const uint8_t*, size_t) with every chunk whose last byte has arrived by time t, in order.
  template <class Sink>
  void deliver_until(double t, Sink&& sink) {
    while (!queue_.empty() && queue_.front().arrival_s <= t) {
      const Pending& p = queue_.front();
      stats_.bytes_delivered += p.bytes.size();
      sink(p.bytes.data(), p.bytes.size());
      queue_.pop_front();
    }
  }

  // When the last byte handed over so far will have arrived (for lockstep flushing and saturation checks).
  double busy_until() const { return busy_until_s_; }
  double byte_time() const { return byte_time_s_; }
  bool idle() const { return queue_.empty(); }
  const LineStats& stats() const { return stats_; }

 private:
  struct Pending {
    double arrival_s;
    std::vector<uint8_t> bytes;
  };

  double byte_time_s_;
  Rng rng_;
  RadioConditions radio_;
  double busy_until_s_ = 0.0;
  std::deque<Pending> queue_;
  LineStats stats_;
};

}  // namespace quad::sim
