// Little-endian field packing for MAVLink payloads, and the three visitors every message definition
// (messages.h) is walked with: a writer, a zero-extending reader and a compile-time size counter.
//
// Every target of this project (AVR, Cortex-M, x86-64) is little-endian, as MAVLink's wire format is, so
// a field is packed with memcpy of its object representation: no alignment assumptions, no shifts of
// 64-bit values on the 8-bit AVR. The #error below stops a big-endian port from silently going wrong.
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#if defined(__BYTE_ORDER__) && (__BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__)
#error "quad_link packs fields with memcpy and needs a little-endian target"
#endif

namespace quad {
namespace mavlink {
namespace wire {

// Writes fields one after the other from `out` (the caller guarantees room for the full payload).
class Writer {
 public:
  explicit Writer(uint8_t* out) : out_(out) {}
  template <class T>
  void operator()(const T& field) {  // scalars and arrays alike: arrays are contiguous
    memcpy(out_ + size_, &field, sizeof(T));
    size_ += sizeof(T);
  }
  void extensions() {}
  size_t size() const { return size_; }

 private:
  uint8_t* out_;
  size_t size_ = 0;
};

// Reads fields from a payload of `length` bytes; bytes past the end read as zero (MAVLink v2 senders
// drop trailing zero bytes, and a v2 receiver of a longer definition zero-fills the extensions).
class Reader {
 public:
  Reader(const uint8_t* payload, size_t length) : payload_(payload), length_(length) {}
  template <class T>
  void operator()(T& field) {
    uint8_t* dst = reinterpret_cast<uint8_t*>(&field);
    const size_t available = offset_ < length_ ? length_ - offset_ : 0;
    const size_t copied = available < sizeof(T) ? available : sizeof(T);
    if (copied > 0) memcpy(dst, payload_ + offset_, copied);
    if (copied < sizeof(T)) memset(dst + copied, 0, sizeof(T) - copied);
    offset_ += sizeof(T);
  }
  void extensions() {}
  void skip(size_t bytes) { offset_ += bytes; }

 private:
  const uint8_t* payload_;
  size_t length_;
  size_t offset_ = 0;
};

// Counts the wire size of a definition at compile time: `length` with extensions, `base_length` without.
struct SizeCounter {
  size_t length = 0;
  size_t base_length = 0;
  bool in_extensions = false;
  template <class T>
  constexpr void operator()(const T&) {
    length += sizeof(T);
    if (!in_extensions) base_length += sizeof(T);
  }
  constexpr void extensions() { in_extensions = true; }
};

template <class Msg>
constexpr SizeCounter count_fields() {
  Msg msg{};
  SizeCounter counter{};
  Msg::fields(msg, counter);
  return counter;
}

// The wire offset of a definition's field number `index` (0 = the first in wire order), at compile time,
// so that a receiver can read single fields of a payload where it is (read_at) instead of copying the
// whole message.
struct OffsetCounter {
  size_t fields_left = 0;
  size_t offset = 0;
  template <class T>
  constexpr void operator()(const T&) {
    if (fields_left == 0) return;
    offset += sizeof(T);
    --fields_left;
  }
  constexpr void extensions() {}
};

template <class Msg>
constexpr size_t field_offset(size_t index) {
  Msg msg{};
  OffsetCounter counter{};
  counter.fields_left = index;
  Msg::fields(msg, counter);
  return counter.offset;
}

// The value at `offset` of a payload of `length` bytes, zero-extended as Reader does.
template <class T>
T read_at(const uint8_t* payload, size_t length, size_t offset) {
  T value;
  Reader reader(payload, length);
  reader.skip(offset);
  reader(value);
  return value;
}

}  // namespace wire
}  // namespace mavlink
}  // namespace quad
