#include "quad/sim/serial_line.h"

#include <algorithm>

namespace quad::sim {

void SerialLine::send(const uint8_t* data, size_t length, double t) {
  ++stats_.frames_sent;
  stats_.bytes_sent += length;
  if (rng_.bernoulli(radio_.loss)) {
    ++stats_.frames_lost;
    return;
  }
  Pending p{0.0, std::vector<uint8_t>(data, data + length)};
  if (radio_.bit_error_rate > 0.0) {
    // Skip straight to the next flipped bit: one geometric draw per error instead of one draw per bit.
    const uint64_t bits = 8ull * length;
    uint64_t flipped = 0;
    for (uint64_t bit = rng_.geometric(radio_.bit_error_rate); bit < bits;
         bit += 1 + rng_.geometric(radio_.bit_error_rate)) {
      p.bytes[bit / 8] ^= static_cast<uint8_t>(1u << (bit % 8));
      ++flipped;
    }
    if (flipped > 0) ++stats_.frames_corrupted;
    stats_.bits_flipped += flipped;
  }
  const double ready = t + radio_.latency_s + (radio_.jitter_s > 0.0 ? rng_.uniform(0.0, radio_.jitter_s) : 0.0);
  // The receiving UART takes the bytes one after the other: no frame overtakes another.
  const double start = std::max(ready, busy_until_s_);
  busy_until_s_ = start + byte_time_s_ * static_cast<double>(length);
  p.arrival_s = busy_until_s_;
  queue_.push_back(std::move(p));
}

}  // namespace quad::sim
