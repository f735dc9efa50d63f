// MAVLink v2 message signing (https://mavlink.io/en/guide/message_signing.html): authenticates frames with
// a 32-byte secret key shared by the vehicle and its ground tools, and rejects replayed frames.
//
// A signed frame (incompat flag 0x01) ends in a 13-byte block:
//   link id (1 byte) | timestamp (6 bytes LE, 10 µs units since 2015-01-01 00:00:00 UTC) | signature (6)
// signature = the first 6 bytes of SHA-256(key + frame[0 .. size - 6)), i.e. of key + header + payload +
// CRC + link id + timestamp, as the MAVLink C library and node-mavlink compute it.
//
// Replay protection follows the C library's mavlink_signature_check(): a stream is the tuple (link id,
// system id, component id); a frame of a known stream is accepted only if its timestamp is strictly newer
// than the stream's last accepted one; a frame opening a new stream only if its timestamp is at most one
// minute behind the local clock. The signature is checked first, so forged frames never create streams or
// move timestamps.
//
// One SigningKey and one SigningClock per system, shared by a Signer per outgoing link and a
// SignatureVerifier per incoming link. The key is read through a reference at every use, so provisioning a
// new key at run time is writing its bytes (then call forget_streams()). Usage:
//   mav::SigningKey key;                       // 32 bytes, e.g. loaded from the parameter store
//   mav::SigningClock clock(stored_timestamp); // restored at start-up; advance_to() real time when known
//   mav::Signer signer(key, clock, /*link_id=*/1);
//   mav::SignatureVerifier verifier(key, clock);
//   verifier.set_require_signed(true);
//   size_t n = mav::encode_signed(sender, signer, msg, buf, sizeof buf);
//   parser.feed(data, length, [&](const mav::Frame& f) { if (mav::accepted(verifier.check(f))) use(f); });
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "quad/link/frame.h"

namespace quad {
namespace mavlink {

constexpr size_t kSigningKeyLength = 32;
constexpr size_t kSignatureHashLength = 6;       // the truncated SHA-256 at the end of the block
constexpr size_t kSignatureLinkIdOffset = 0;     // within the 13-byte block
constexpr size_t kSignatureTimestampOffset = 1;
constexpr size_t kSignatureHashOffset = 7;
constexpr uint64_t kMaxSigningTimestamp = (static_cast<uint64_t>(1) << 48) - 1;
constexpr uint64_t kSigningTicksPerSecond = 100000;       // 10 µs units
constexpr uint64_t kSigningEpochUnixSeconds = 1420070400;  // 2015-01-01 00:00:00 UTC
// How far behind the local clock a frame opening a new stream may be (the spec's one minute; the C
// library's 6000 * 1000).
constexpr uint64_t kNewStreamMaxAge = 60 * kSigningTicksPerSecond;

struct SigningKey {
  uint8_t bytes[kSigningKeyLength];
};

// The signing timestamp of a Unix time in microseconds (0 before 2015).
inline uint64_t signing_timestamp_from_unix_microseconds(uint64_t unix_microseconds) {
  const uint64_t epoch = kSigningEpochUnixSeconds * 1000000u;
  return unix_microseconds > epoch ? (unix_microseconds - epoch) / 10u : 0u;
}

// The local signing timestamp of a system. It never goes backward: the caller advances it to real time
// when it has one (RTC, GPS) and to the value saved in persistent storage at start-up (the spec asks to
// save it at least once a minute, so that a reboot cannot reuse timestamps); verifiers advance it to every
// newer timestamp they accept; every frame signed takes the current value and moves it on by one unit, so
// frames get distinct, increasing timestamps even faster than 100 000 per second.
class SigningClock {
 public:
  explicit SigningClock(uint64_t timestamp = 0) : now_(timestamp < kMaxSigningTimestamp ? timestamp : kMaxSigningTimestamp) {}

  void advance_to(uint64_t timestamp) {
    if (timestamp > kMaxSigningTimestamp) timestamp = kMaxSigningTimestamp;
    if (timestamp > now_) now_ = timestamp;
  }
  uint64_t now() const { return now_; }

  // The timestamp for the next frame sent. False when the 48-bit range is used up (in 2104).
  bool take(uint64_t* timestamp) {
    if (now_ >= kMaxSigningTimestamp) return false;
    *timestamp = now_++;
    return true;
  }

 private:
  uint64_t now_;
};

// The 6-byte signature of frame[0 .. size - 6) under `key` (the frame's own last 6 bytes are not read).
// `size` must be at least 6.
void compute_signature(const SigningKey& key, const uint8_t* frame, size_t size,
                       uint8_t signature[kSignatureHashLength]);

// Signs outgoing frames of one link.
class Signer {
 public:
  Signer(const SigningKey& key, SigningClock& clock, uint8_t link_id) : key_(key), clock_(clock), link_id_(link_id) {}

  // Fills the signature block of a frame encoded with kIncompatFlagSigned (encode() reserves the block):
  // link id, the clock's next timestamp, the signature. False, and the frame untouched, when `frame` is
  // not a whole signed MAVLink v2 frame of `size` bytes or the clock is exhausted.
  bool sign(uint8_t* frame, size_t size);

  uint8_t link_id() const { return link_id_; }
  void set_link_id(uint8_t link_id) { link_id_ = link_id; }

 private:
  const SigningKey& key_;
  SigningClock& clock_;
  uint8_t link_id_;
};

// Encodes `msg` with `sender` as a signed frame and signs it: the frame length, or 0 when the buffer is
// too small (capacity < max_frame_length<Msg>(true)) or the clock is exhausted (the sender's sequence
// number has advanced then).
template <class Msg>
size_t encode_signed(Sender& sender, Signer& signer, const Msg& msg, uint8_t* out, size_t capacity) {
  const size_t size = sender.encode(msg, out, capacity, kIncompatFlagSigned);
  return size > 0 && signer.sign(out, size) ? size : 0;
}

// As encode_signed() for a payload write_payload() already put in `out` (Sender::finish()).
size_t finish_signed(Sender& sender, Signer& signer, uint32_t message_id, uint8_t crc_extra, size_t full_length,
                     uint8_t* out);

// The outcome of SignatureVerifier::check(), one rejection reason each.
enum class SignatureCheck : uint8_t {
  kAcceptedSigned,
  kAcceptedUnsigned,        // unsigned, and signing not required or the message is allowed unsigned
  kRejectedUnsigned,        // unsigned while signing is required
  kRejectedBadSignature,    // wrong key, or any byte changed after signing
  kRejectedReplay,          // timestamp not newer than the last accepted one of its stream
  kRejectedOldTimestamp,    // opens a new stream with a timestamp over a minute behind the local clock
  kRejectedTooManyStreams,  // opens a new stream while all kMaxStreams slots are taken
};

inline bool accepted(SignatureCheck check) {
  return check == SignatureCheck::kAcceptedSigned || check == SignatureCheck::kAcceptedUnsigned;
}

struct SignatureStats {
  uint32_t accepted_signed = 0;
  uint32_t accepted_unsigned = 0;
  uint32_t rejected_unsigned = 0;
  uint32_t bad_signature = 0;
  uint32_t replayed = 0;
  uint32_t old_timestamp = 0;
  uint32_t too_many_streams = 0;

  uint32_t rejected() const { return rejected_unsigned + bad_signature + replayed + old_timestamp + too_many_streams; }
};

// Checks the signature and the timestamp of received frames (one verifier per incoming link) and counts
// the outcomes.
class SignatureVerifier {
 public:
  static constexpr uint8_t kMaxStreams = 8;  // senders a vehicle hears: ground tools, vision station, ...

  // Decides which messages pass unsigned while signing is required (the spec lets a system accept e.g.
  // RADIO_STATUS from a radio modem that cannot sign).
  typedef bool (*UnsignedPolicy)(uint32_t message_id);

  SignatureVerifier(const SigningKey& key, SigningClock& clock) : key_(key), clock_(clock) {}

  // Off (the default): unsigned frames pass; signed frames are still checked, since a frame that carries
  // a wrong signature is forged or damaged either way.
  void set_require_signed(bool require) { require_signed_ = require; }
  bool require_signed() const { return require_signed_; }
  void set_unsigned_policy(UnsignedPolicy policy) { unsigned_policy_ = policy; }

  // Checks a frame delivered by the Parser (CRC already verified). Accepting a signed frame records its
  // timestamp for its stream and advances the clock.
  SignatureCheck check(const Frame& frame);

  // Forgets every stream's last timestamp (after a key change: streams under the old key are over).
  void forget_streams() { stream_count_ = 0; }

  const SignatureStats& stats() const { return stats_; }
  uint8_t stream_count() const { return stream_count_; }

 private:
  struct Stream {
    uint64_t last_timestamp;
    uint8_t link_id;
    uint8_t system_id;
    uint8_t component_id;
  };

  SignatureCheck check_signed(const Frame& frame);
  SignatureCheck count(SignatureCheck outcome);

  const SigningKey& key_;
  SigningClock& clock_;
  UnsignedPolicy unsigned_policy_ = nullptr;
  bool require_signed_ = false;
  uint8_t stream_count_ = 0;
  Stream streams_[kMaxStreams];
  SignatureStats stats_;
};

}  // namespace mavlink
}  // namespace quad
