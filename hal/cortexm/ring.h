// Single-producer single-consumer byte ring between an interrupt handler and the main loop.
#pragma once

#include <stdint.h>

namespace quad {
namespace hal {
namespace cortexm {

template <uint16_t kSize>
class ByteRing {
  static_assert(kSize >= 2 && (kSize & (kSize - 1)) == 0, "ring size: a power of two");

 public:
  bool empty() const { return head_ == tail_; }
  uint16_t free_space() const { return static_cast<uint16_t>(kSize - 1u - ((head_ - tail_) & (kSize - 1u))); }
  bool push(uint8_t b) {
    const uint16_t next = static_cast<uint16_t>((head_ + 1u) & (kSize - 1u));
    if (next == tail_) return false;
    data_[head_] = b;
    head_ = next;  // volatile store after the data: the consumer sees a complete byte
    return true;
  }
  uint8_t pop() {
    const uint8_t b = data_[tail_];
    tail_ = static_cast<uint16_t>((tail_ + 1u) & (kSize - 1u));
    return b;
  }

 private:
  uint8_t data_[kSize];
  volatile uint16_t head_ = 0;
  volatile uint16_t tail_ = 0;
};

}  // namespace cortexm
}  // namespace hal
}  // namespace quad
