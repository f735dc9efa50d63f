// Streaming MAVLink v2 parser (see parser.h for the contract).
#include "quad/link/parser.h"

#include <string.h>

#include "quad/link/crc.h"

namespace quad {
namespace mavlink {

// The bytes push()'s fast path leaves: a frame to release, a start byte, a byte that completes a check.
bool Parser::push_checked(uint8_t byte) {
  if (ready_ > 0) {  // the caller moved on without next(): release the frame first
    drop_front(ready_);
    ready_ = 0;
  }
  // Noise between frames is discarded without touching the buffer.
  if (held_ == 0 && byte != kStx) {
    ++stats_.bytes_discarded;
    return false;
  }
  // Cannot trigger while the invariant holds (a partial candidate is shorter than kMaxFrameLength); kept
  // so that no sequence of calls can ever write past the buffer.
  if (held_ >= kMaxFrameLength) resynchronise();
  buffer_[held_++] = byte;
  return scan();
}

bool Parser::next() {
  if (ready_ == 0) return false;
  drop_front(ready_);
  ready_ = 0;
  return scan();
}

void Parser::reset() {
  stats_.bytes_discarded += static_cast<uint32_t>(held_ - ready_);
  held_ = 0;
  scanned_ = 0;
  expected_ = 0;
  ready_ = 0;
}

const SenderStats* Parser::find_sender(uint8_t system_id, uint8_t component_id) const {
  for (uint8_t i = 0; i < sender_count_; ++i) {
    if (senders_[i].system_id == system_id && senders_[i].component_id == component_id) return &senders_[i];
  }
  return nullptr;
}

// Extends the checked prefix over the held bytes until a frame completes or the bytes run out.
bool Parser::scan() {
  while (scanned_ < held_) {
    ++scanned_;
    switch (check_prefix()) {
      case Check::kNeedMore:
        break;
      case Check::kComplete:
        accept();
        return true;
      case Check::kReject:
        resynchronise();
        break;
    }
  }
  return false;
}

// Checks the candidate frame buffer_[0 .. scanned_) at the points where a new check becomes possible.
Parser::Check Parser::check_prefix() {
  if (scanned_ == 1) return buffer_[0] == kStx ? Check::kNeedMore : Check::kReject;
  if (scanned_ < kHeaderLength) return Check::kNeedMore;

  if (scanned_ == kHeaderLength) {
    const uint8_t incompat_flags = buffer_[2];
    if ((incompat_flags & static_cast<uint8_t>(~kSupportedIncompatFlags)) != 0) {
      ++stats_.unsupported_flags;
      return Check::kReject;
    }
    const uint32_t message_id = static_cast<uint32_t>(buffer_[7]) | (static_cast<uint32_t>(buffer_[8]) << 8) |
                                (static_cast<uint32_t>(buffer_[9]) << 16);
    if (!lookup_(message_id, &info_)) {
      ++stats_.unknown_message;
      return Check::kReject;
    }
    if (buffer_[1] > info_.max_length) {
      ++stats_.bad_length;
      return Check::kReject;
    }
    const bool is_signed = (incompat_flags & kIncompatFlagSigned) != 0;
    expected_ = static_cast<uint16_t>(kHeaderLength + buffer_[1] + kChecksumLength +
                                      (is_signed ? kSignatureLength : 0));
    return Check::kNeedMore;
  }

  if (scanned_ < expected_) return Check::kNeedMore;

  const size_t crc_at = kHeaderLength + buffer_[1];
  uint16_t crc = crc_accumulate(buffer_ + 1, crc_at - 1, kCrcInit);
  crc = crc_accumulate(info_.crc_extra, crc);
  if (buffer_[crc_at] != static_cast<uint8_t>(crc & 0xFF) || buffer_[crc_at + 1] != static_cast<uint8_t>(crc >> 8)) {
    ++stats_.bad_checksum;
    return Check::kReject;
  }
  return Check::kComplete;
}

void Parser::drop_front(size_t count) {
  memmove(buffer_, buffer_ + count, held_ - count);
  held_ = static_cast<uint16_t>(held_ - count);
}

// Discards the rejected candidate's start byte and any bytes before the next start byte held after it;
// the scan then restarts there, so a frame beginning inside the rejected candidate is not lost.
void Parser::resynchronise() {
  uint16_t next_start = 1;
  while (next_start < held_ && buffer_[next_start] != kStx) ++next_start;
  stats_.bytes_discarded += next_start;
  drop_front(next_start);
  scanned_ = 0;
  expected_ = 0;
}

void Parser::accept() {
  ready_ = scanned_;
  frame_.payload_length = buffer_[1];
  frame_.incompat_flags = buffer_[2];
  frame_.compat_flags = buffer_[3];
  frame_.sequence = buffer_[4];
  frame_.system_id = buffer_[5];
  frame_.component_id = buffer_[6];
  frame_.message_id = static_cast<uint32_t>(buffer_[7]) | (static_cast<uint32_t>(buffer_[8]) << 8) |
                      (static_cast<uint32_t>(buffer_[9]) << 16);
  frame_.payload = buffer_ + kHeaderLength;
  const bool is_signed = (frame_.incompat_flags & kIncompatFlagSigned) != 0;
  frame_.signature = is_signed ? buffer_ + kHeaderLength + frame_.payload_length + kChecksumLength : nullptr;
  frame_.bytes = buffer_;
  frame_.size = ready_;
  scanned_ = 0;
  expected_ = 0;
  ++stats_.frames_accepted;
  track_sequence();
}

void Parser::track_sequence() {
  for (uint8_t i = 0; i < sender_count_; ++i) {
    SenderStats& sender = senders_[i];
    if (sender.system_id == frame_.system_id && sender.component_id == frame_.component_id) {
      const uint8_t gap = static_cast<uint8_t>(frame_.sequence - sender.last_sequence - 1);
      sender.lost += gap;
      stats_.sequence_lost += gap;
      sender.last_sequence = frame_.sequence;
      ++sender.received;
      return;
    }
  }
  if (sender_count_ == kMaxSenders) {
    ++stats_.untracked_sender_frames;
    return;
  }
  SenderStats& added = senders_[sender_count_++];
  added.system_id = frame_.system_id;
  added.component_id = frame_.component_id;
  added.last_sequence = frame_.sequence;
  added.received = 1;
  added.lost = 0;
}

}  // namespace mavlink
}  // namespace quad
