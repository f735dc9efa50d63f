// MAVLink v2 message signing: see signing.h.
#include "quad/link/signing.h"

#include "quad/link/sha256.h"

namespace quad {
namespace mavlink {

namespace {

uint64_t read_timestamp(const uint8_t* p) {
  uint64_t value = 0;
  for (uint8_t i = 6; i-- > 0;) value = (value << 8) | p[i];
  return value;
}

void write_timestamp(uint64_t value, uint8_t* p) {
  for (uint8_t i = 0; i < 6; ++i) {
    p[i] = static_cast<uint8_t>(value);
    value >>= 8;
  }
}

// Compares every byte whatever the first difference, so the time taken does not tell an attacker how
// many leading bytes of a forged signature are right.
bool same_signature(const uint8_t* a, const uint8_t* b) {
  uint8_t difference = 0;
  for (uint8_t i = 0; i < kSignatureHashLength; ++i) difference = static_cast<uint8_t>(difference | (a[i] ^ b[i]));
  return difference == 0;
}

// True when frame[0 .. size) is exactly one signed MAVLink v2 frame as its header describes it.
bool is_whole_signed_frame(const uint8_t* frame, size_t size) {
  return frame != nullptr && size >= kHeaderLength && frame[0] == kStx &&
         (frame[2] & kIncompatFlagSigned) != 0 &&
         size == kHeaderLength + frame[1] + kChecksumLength + kSignatureLength;
}

}  // namespace

void compute_signature(const SigningKey& key, const uint8_t* frame, size_t size,
                       uint8_t signature[kSignatureHashLength]) {
  Sha256 hash;
  hash.update(key.bytes, kSigningKeyLength);
  hash.update(frame, size - kSignatureHashLength);
  hash.finish(signature, kSignatureHashLength);
}

bool Signer::sign(uint8_t* frame, size_t size) {
  if (!is_whole_signed_frame(frame, size)) return false;
  uint64_t timestamp = 0;
  if (!clock_.take(&timestamp)) return false;
  uint8_t* block = frame + size - kSignatureLength;
  block[kSignatureLinkIdOffset] = link_id_;
  write_timestamp(timestamp, block + kSignatureTimestampOffset);
  compute_signature(key_, frame, size, block + kSignatureHashOffset);
  return true;
}

SignatureCheck SignatureVerifier::check(const Frame& frame) {
  if (frame.is_signed()) return count(check_signed(frame));
  if (!require_signed_ || (unsigned_policy_ != nullptr && unsigned_policy_(frame.message_id))) {
    return count(SignatureCheck::kAcceptedUnsigned);
  }
  return count(SignatureCheck::kRejectedUnsigned);
}

// The order of mavlink_signature_check() in the MAVLink C library: signature, then stream and timestamp.
SignatureCheck SignatureVerifier::check_signed(const Frame& frame) {
  if (!is_whole_signed_frame(frame.bytes, frame.size) || frame.signature != frame.bytes + frame.size - kSignatureLength) {
    return SignatureCheck::kRejectedBadSignature;
  }
  uint8_t expected[kSignatureHashLength];
  compute_signature(key_, frame.bytes, frame.size, expected);
  if (!same_signature(expected, frame.signature + kSignatureHashOffset)) return SignatureCheck::kRejectedBadSignature;

  const uint8_t link_id = frame.signature[kSignatureLinkIdOffset];
  const uint64_t timestamp = read_timestamp(frame.signature + kSignatureTimestampOffset);
  Stream* stream = nullptr;
  for (uint8_t i = 0; i < stream_count_; ++i) {
    Stream& s = streams_[i];
    if (s.link_id == link_id && s.system_id == frame.system_id && s.component_id == frame.component_id) {
      stream = &s;
      break;
    }
  }
  if (stream != nullptr) {
    if (timestamp <= stream->last_timestamp) return SignatureCheck::kRejectedReplay;
  } else {
    if (stream_count_ == kMaxStreams) return SignatureCheck::kRejectedTooManyStreams;
    if (timestamp + kNewStreamMaxAge < clock_.now()) return SignatureCheck::kRejectedOldTimestamp;
    stream = &streams_[stream_count_++];
    stream->link_id = link_id;
    stream->system_id = frame.system_id;
    stream->component_id = frame.component_id;
  }
  stream->last_timestamp = timestamp;
  clock_.advance_to(timestamp);
  return SignatureCheck::kAcceptedSigned;
}

SignatureCheck SignatureVerifier::count(SignatureCheck outcome) {
  switch (outcome) {
    case SignatureCheck::kAcceptedSigned: ++stats_.accepted_signed; break;
    case SignatureCheck::kAcceptedUnsigned: ++stats_.accepted_unsigned; break;
    case SignatureCheck::kRejectedUnsigned: ++stats_.rejected_unsigned; break;
    case SignatureCheck::kRejectedBadSignature: ++stats_.bad_signature; break;
    case SignatureCheck::kRejectedReplay: ++stats_.replayed; break;
    case SignatureCheck::kRejectedOldTimestamp: ++stats_.old_timestamp; break;
    case SignatureCheck::kRejectedTooManyStreams: ++stats_.too_many_streams; break;
  }
  return outcome;
}

size_t finish_signed(Sender& sender, Signer& signer, uint32_t message_id, uint8_t crc_extra, size_t full_length,
                     uint8_t* out) {
  const size_t size = sender.finish(message_id, crc_extra, full_length, out, kIncompatFlagSigned);
  return size > 0 && signer.sign(out, size) ? size : 0;
}

}  // namespace mavlink
}  // namespace quad
