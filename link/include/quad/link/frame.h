// MAVLink v2 framing: the frame layout, encoding a message into a caller's buffer, and decoding a
// received frame (see parser.h) back into a message struct.
//
//   byte  0      STX 0xFD
//         1      payload length (after trailing-zero truncation)
//         2      incompat_flags (0x01: signed; any other bit set: the receiver must drop the frame)
//         3      compat_flags
//         4      sequence
//         5, 6   system id, component id
//         7..9   message id, 24-bit little-endian
//         10..   payload (fields in wire order, trailing zero bytes dropped)
//         +2     CRC-16/MCRF4XX over bytes 1..end of payload, then over the message's CRC_EXTRA
//         +13    signature block when incompat_flags & 0x01: link id, 48-bit timestamp, 48-bit signature
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "quad/link/wire.h"

namespace quad {
namespace mavlink {

constexpr uint8_t kStx = 0xFD;
constexpr size_t kHeaderLength = 10;
constexpr size_t kChecksumLength = 2;
constexpr size_t kSignatureLength = 13;
constexpr size_t kMaxPayloadLength = 255;
constexpr size_t kMaxFrameLength = kHeaderLength + kMaxPayloadLength + kChecksumLength + kSignatureLength;  // 280
constexpr uint8_t kIncompatFlagSigned = 0x01;
constexpr uint8_t kSupportedIncompatFlags = kIncompatFlagSigned;

// What an encoder puts in the header besides the message id and length.
struct FrameHeader {
  uint8_t system_id = 0;
  uint8_t component_id = 0;
  uint8_t sequence = 0;
  uint8_t incompat_flags = 0;  // kIncompatFlagSigned reserves the signature block (see encode())
  uint8_t compat_flags = 0;
};

// A received, CRC-checked frame. It views the parser's buffer: valid until the next Parser::push() or
// Parser::next() call.
struct Frame {
  uint8_t payload_length = 0;  // as received, i.e. possibly truncated; decode() zero-extends
  uint8_t incompat_flags = 0;
  uint8_t compat_flags = 0;
  uint8_t sequence = 0;
  uint8_t system_id = 0;
  uint8_t component_id = 0;
  uint32_t message_id = 0;
  const uint8_t* payload = nullptr;
  // The 13-byte signature block (link id, timestamp, signature) of a signed frame, or nullptr. The parser
  // does not verify signatures: SignatureVerifier (signing.h) checks them over `bytes` (SHA-256 of key +
  // bytes[0 .. size - 6)).
  const uint8_t* signature = nullptr;
  const uint8_t* bytes = nullptr;  // the whole frame, STX to the last signature byte
  uint16_t size = 0;

  bool is_signed() const { return signature != nullptr; }
};

// What a receiver needs to know about a message id to check a frame.
struct MessageInfo {
  uint8_t crc_extra;
  uint8_t max_length;  // payload length with all extension fields
};

// Looks up a message id; false when the id is unknown. The parser takes one of these, so a tool can
// accept more messages than the flight code knows.
typedef bool (*MessageInfoLookup)(uint32_t message_id, MessageInfo* info);

// The messages of messages.h.
bool find_message_info(uint32_t message_id, MessageInfo* info);

template <class Msg>
constexpr MessageInfo message_info() {
  return MessageInfo{Msg::kCrcExtra, Msg::kLength};
}

// The buffer capacity encode() requires for a message: the untruncated frame (plus the signature block
// when signing). Truncation happens in place, so the frame it returns is often shorter.
template <class Msg>
constexpr size_t max_frame_length(bool is_signed = false) {
  return kHeaderLength + Msg::kLength + kChecksumLength + (is_signed ? kSignatureLength : 0);
}

// Completes a frame whose full, untruncated payload (`full_length` bytes) is already at
// out + kHeaderLength: writes the header, drops trailing zero bytes of the payload, appends the CRC and,
// when the header asks for signing, a zeroed signature block. Returns the frame length.
size_t finish_frame(const FrameHeader& header, uint32_t message_id, uint8_t crc_extra, size_t full_length,
                    uint8_t* out);

// Writes the full, untruncated payload of `msg` at out + kHeaderLength (out must hold
// max_frame_length<Msg>()), for finish_frame() or Sender::finish() to complete. The only part of encoding
// that depends on the message type: code that sends many types writes the payload in a small template
// and finishes the frame in one shared function (on the AVR every inlined copy of the finishing costs
// flash).
template <class Msg>
void write_payload(const Msg& msg, uint8_t* out) {
  wire::Writer writer(out + kHeaderLength);
  Msg::fields(msg, writer);
}

// Encodes `msg` as a MAVLink v2 frame into out[0 .. capacity). Returns the frame length, or 0 (nothing
// usable written) when capacity < max_frame_length<Msg>(signed) or the header carries an incompat flag
// this codec does not implement. With kIncompatFlagSigned set the frame ends in a zeroed 13-byte
// signature block for a signing layer to fill in (the CRC already covers the flag). Never allocates.
template <class Msg>
size_t encode(const Msg& msg, const FrameHeader& header, uint8_t* out, size_t capacity) {
  if ((header.incompat_flags & static_cast<uint8_t>(~kSupportedIncompatFlags)) != 0) return 0;
  const bool is_signed = (header.incompat_flags & kIncompatFlagSigned) != 0;
  if (out == nullptr || capacity < max_frame_length<Msg>(is_signed)) return 0;
  write_payload(msg, out);
  return finish_frame(header, Msg::kId, Msg::kCrcExtra, Msg::kLength, out);
}

// Decodes a received frame into `out`. False (and `out` untouched) when the frame carries another
// message or a payload longer than this definition. Truncated payloads and missing extension fields
// read as zero.
template <class Msg>
bool decode(const Frame& frame, Msg& out) {
  if (frame.message_id != Msg::kId || frame.payload_length > Msg::kLength) return false;
  wire::Reader reader(frame.payload, frame.payload_length);
  Msg::fields(out, reader);
  return true;
}

// One sender's identity and its sequence counter (MAVLink counts per sender and link): use one per
// port and component.
class Sender {
 public:
  Sender(uint8_t system_id, uint8_t component_id) : system_id_(system_id), component_id_(component_id) {}

  // As mavlink::encode(); the sequence number advances only when a frame was written. With
  // kIncompatFlagSigned the frame ends in a zeroed signature block (see encode_signed() in signing.h).
  template <class Msg>
  size_t encode(const Msg& msg, uint8_t* out, size_t capacity, uint8_t incompat_flags = 0) {
    if (out == nullptr || capacity < max_frame_length<Msg>((incompat_flags & kIncompatFlagSigned) != 0)) return 0;
    write_payload(msg, out);
    return finish(Msg::kId, Msg::kCrcExtra, Msg::kLength, out, incompat_flags);
  }

  // Completes a frame whose full payload (`full_length` bytes) write_payload() put at out +
  // kHeaderLength, with this sender's identity and next sequence number; the buffer must hold the
  // untruncated frame (plus the signature block with kIncompatFlagSigned). Returns the frame length, or
  // 0 for an incompat flag this codec does not implement (the sequence number then stays).
  size_t finish(uint32_t message_id, uint8_t crc_extra, size_t full_length, uint8_t* out, uint8_t incompat_flags = 0);

  uint8_t system_id() const { return system_id_; }
  uint8_t component_id() const { return component_id_; }
  uint8_t next_sequence() const { return sequence_; }

 private:
  uint8_t system_id_;
  uint8_t component_id_;
  uint8_t sequence_ = 0;
};

}  // namespace mavlink
}  // namespace quad
