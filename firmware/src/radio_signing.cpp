#include "quad/firmware/radio_signing.h"

#include <string.h>

#include "quad/firmware/storage_layout.h"

namespace quad {
namespace fw {
namespace mav = ::quad::mavlink;
namespace {

constexpr RecordLayout kKeyRecord{kSigningKeyOffset, kSigningKeyPayload, 0x4B53};      // "SK"
constexpr RecordLayout kClockRecord{kSigningClockOffset, kSigningClockPayload, 0x5453};  // "ST"

bool all_zero(const uint8_t* p, size_t n) {
  uint8_t any = 0;
  for (size_t i = 0; i < n; ++i) any |= p[i];
  return any == 0;
}

}  // namespace

bool RadioSigning::load(const StorageIo& io) {
  const RecordStatus key_status = record_load(io, kKeyRecord, key_.bytes);
  has_key_ = key_status == RecordStatus::kLoaded && !all_zero(key_.bytes, sizeof key_.bytes);
  if (!has_key_) memset(key_.bytes, 0, sizeof key_.bytes);
  uint8_t stored[kSigningClockPayload];
  if (record_load(io, kClockRecord, stored) == RecordStatus::kLoaded) {
    uint64_t t = 0;
    for (int i = kSigningClockPayload - 1; i >= 0; --i) t = (t << 8) | stored[i];
    // Past the timestamps used since the last save (MAVLink signing spec: jump ahead at boot).
    clock_.advance_to(t + kBootJump);
  }
  persisted_mark_ = clock_.now();
  verifier_.forget_streams();
  return key_status == RecordStatus::kLoaded || key_status == RecordStatus::kEmpty;
}

void RadioSigning::set_enabled(bool enabled) {
  enabled_ = enabled;
  verifier_.set_require_signed(enabled);
}

mav::SignatureCheck RadioSigning::check(const mav::Frame& frame) {
  if (enabled_ && !has_key_) {
    ++rejected_no_key_;
    return frame.is_signed() ? mav::SignatureCheck::kRejectedBadSignature : mav::SignatureCheck::kRejectedUnsigned;
  }
  return verifier_.check(frame);
}

RadioSigning::Provisioned RadioSigning::provision(const StorageIo& io, const mavlink::SetupSigning& msg) {
  const bool off = all_zero(msg.secret_key, sizeof msg.secret_key) && msg.initial_timestamp == 0;
  memcpy(key_.bytes, msg.secret_key, sizeof key_.bytes);
  has_key_ = !all_zero(key_.bytes, sizeof key_.bytes);
  clock_.advance_to(msg.initial_timestamp);
  verifier_.forget_streams();  // streams under the old key are over
  const bool saved = record_save(io, kKeyRecord, key_.bytes) && save_clock(io);
  if (!saved) return Provisioned::kStorageFailed;
  return off ? Provisioned::kSigningOff : Provisioned::kKeySet;
}

void RadioSigning::persist_clock(const StorageIo& io, uint32_t now_us, bool force) {
  if (!save_started_) {
    save_started_ = true;
    last_save_us_ = now_us;
  }
  const bool due = static_cast<uint32_t>(now_us - last_save_us_) >= kClockSavePeriodUs;
  // Nothing to save while the clock has not moved (no boot-jump drift on a vehicle nobody talks to).
  if (!(force || due) || clock_.now() <= persisted_mark_) return;
  last_save_us_ = now_us;
  save_clock(io);
}

bool RadioSigning::save_clock(const StorageIo& io) {
  uint8_t bytes[kSigningClockPayload];
  uint64_t t = clock_.now();
  for (uint8_t i = 0; i < kSigningClockPayload; ++i, t >>= 8) bytes[i] = static_cast<uint8_t>(t);
  if (!record_save(io, kClockRecord, bytes)) return false;
  persisted_mark_ = clock_.now();
  ++clock_saves_;
  return true;
}

}  // namespace fw
}  // namespace quad
