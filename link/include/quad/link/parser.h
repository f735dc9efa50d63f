// Streaming MAVLink v2 parser: one byte at a time, no allocation, one 280-byte frame buffer.
//
// Every byte ends up either in an accepted frame or counted in stats().bytes_discarded. A frame is
// accepted when its header names a known message (see MessageInfoLookup), carries no incompat flag other
// than "signed", has a payload no longer than the message's full definition, and its CRC (with
// CRC_EXTRA) matches. Frames of unknown message ids cannot be CRC-checked (no CRC_EXTRA), so they are
// dropped at the header and counted in unknown_message; so is a false start byte in noise whose header
// names an unknown id, so that counter is an upper bound on real unknown frames.
//
// Resynchronisation: when a candidate frame fails any check, only its start byte is discarded and the
// bytes held after it are scanned again for the next start byte. A valid frame that starts inside a
// rejected candidate (noise ending in a false 0xFD, a frame cut short by a dropped byte) is therefore
// still found. Because such a rescan can complete a frame that was already held, one pushed byte can
// complete more than one frame: after push() returns true, call next() until it returns false, or use
// feed(), which does that for you.
//
// The parser does not verify signatures; it exposes the signature block in Frame for SignatureVerifier
// (signing.h).
//
// Sequence numbers are tracked per sender (system id, component id) for link-loss statistics: a jump from
// s to s + k counts k - 1 lost frames (modulo 256, so a sender restarting its count shows as a gap). Up to kMaxSenders senders are tracked; frames of further senders
// are still accepted and counted in untracked_sender_frames.
//
// Usage:
//   quad::mavlink::Parser parser;
//   parser.feed(byte, [&](const quad::mavlink::Frame& frame) {
//     quad::mavlink::HilSensor sensor;
//     if (quad::mavlink::decode(frame, sensor)) { ... }
//   });
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "quad/link/frame.h"

namespace quad {
namespace mavlink {

struct ParserStats {
  uint32_t frames_accepted = 0;
  uint32_t bytes_discarded = 0;     // bytes that are not part of an accepted frame
  uint32_t bad_checksum = 0;        // candidates whose CRC did not match
  uint32_t bad_length = 0;          // payload longer than the message's full definition
  uint32_t unknown_message = 0;     // headers naming a message id the lookup does not know
  uint32_t unsupported_flags = 0;   // headers with an incompat flag other than "signed"
  uint32_t sequence_lost = 0;       // frames missing from sequence gaps, all senders
  uint32_t untracked_sender_frames = 0;  // accepted frames of senders beyond kMaxSenders
};

struct SenderStats {
  uint8_t system_id = 0;
  uint8_t component_id = 0;
  uint8_t last_sequence = 0;
  uint32_t received = 0;
  uint32_t lost = 0;  // sum of sequence gaps
};

class Parser {
 public:
  static constexpr uint8_t kMaxSenders = 4;

  explicit Parser(MessageInfoLookup lookup = find_message_info) : lookup_(lookup) {}
  Parser(const Parser&) = delete;  // frame() views the parser's own buffer
  Parser& operator=(const Parser&) = delete;

  // Takes one byte. True when a frame is complete: read it with frame(), then call next() until false.
  bool push(uint8_t byte) {
    // Fast path for most bytes (it halves the cost per byte on the AVR): noise between frames, and bytes
    // of a candidate before the point where the next check becomes possible (the end of the header, then
    // the end of the frame).
    if (ready_ == 0 && scanned_ == held_) {
      if (held_ == 0) {
        if (byte != kStx) {
          ++stats_.bytes_discarded;
          return false;
        }
      } else if (held_ + 1u < (held_ < kHeaderLength ? kHeaderLength : expected_)) {
        buffer_[held_++] = byte;
        scanned_ = held_;
        return false;
      }
    }
    return push_checked(byte);
  }

  // Releases the current frame and scans the bytes still held. True when that completes another frame.
  bool next();

  // The frame completed by the last push() or next() that returned true.
  const Frame& frame() const { return frame_; }

  // Pushes one byte or a buffer and calls on_frame(const Frame&) for every frame completed.
  template <class OnFrame>
  void feed(uint8_t byte, OnFrame&& on_frame) {
    for (bool ready = push(byte); ready; ready = next()) on_frame(frame_);
  }
  template <class OnFrame>
  void feed(const uint8_t* data, size_t length, OnFrame&& on_frame) {
    for (size_t i = 0; i < length; ++i) feed(data[i], on_frame);
  }

  // Forgets held bytes (e.g. after reopening a port); statistics are kept.
  void reset();

  const ParserStats& stats() const { return stats_; }
  uint8_t sender_count() const { return sender_count_; }
  const SenderStats& sender(uint8_t index) const { return senders_[index]; }
  // The statistics of one sender, or nullptr when it is not tracked.
  const SenderStats* find_sender(uint8_t system_id, uint8_t component_id) const;

  // Bytes held that are neither in the current frame nor discarded yet (a partial candidate, or bytes
  // waiting for a rescan). Bytes pushed = sizes of accepted frames + bytes_discarded + held_bytes().
  size_t held_bytes() const { return static_cast<size_t>(held_ - ready_); }

 private:
  enum class Check : uint8_t { kNeedMore, kComplete, kReject };

  bool push_checked(uint8_t byte);
  bool scan();
  Check check_prefix();
  void drop_front(size_t count);
  void resynchronise();
  void accept();
  void track_sequence();

  // The per-byte state comes first: the AVR reaches members within 63 bytes of the object's start with
  // one displacement load, members behind the 280-byte buffer need address arithmetic on every access.
  MessageInfoLookup lookup_;
  uint16_t held_ = 0;      // bytes in buffer_
  uint16_t scanned_ = 0;   // leading bytes of buffer_ already checked as a frame prefix
  uint16_t expected_ = 0;  // the candidate's full length, known once its header is complete
  uint16_t ready_ = 0;     // length of the accepted frame at the front of buffer_, 0 when none
  MessageInfo info_ = MessageInfo{0, 0};
  ParserStats stats_;
  uint8_t buffer_[kMaxFrameLength];
  Frame frame_;
  SenderStats senders_[kMaxSenders];
  uint8_t sender_count_ = 0;
};

}  // namespace mavlink
}  // namespace quad
