// MAVLink v2 signing of the radio link (UART2): who may command the vehicle over the air.
//
// With SIGN_ENABLE set and a key provisioned, every frame sent on the radio is signed and every frame
// received on it must carry a valid signature under the key with a timestamp newer than its stream's last
// one (quad/link/signing.h: unsigned, wrongly signed and replayed frames are rejected and counted). With
// SIGN_ENABLE set and no key the radio is closed: every received frame is rejected (fail closed: a lost
// key must not reopen the vehicle to strangers). The USB port (UART0, the HIL link) is never signed.
//
// The key comes only over UART0 as SETUP_SIGNING and is stored as a redundant record. The signing clock
// is stored too, at most every kClockSavePeriodUs while disarmed and at every disarm (an AVR EEPROM write
// blocks the loop, so not in flight), and starts kBootJump ahead of the stored value at boot (the MAVLink
// spec's advice), so timestamps used before a reboot are not reused after it. The clock moves with every
// frame signed and every newer timestamp accepted (the ground station signs with its wall clock); it does
// not follow the vehicle's own time, which in lockstep HIL runs faster than real time.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "quad/firmware/redundant_record.h"
#include "quad/link/dialect.h"
#include "quad/link/signing.h"

namespace quad {
namespace fw {

struct RadioSigningStats {
  mavlink::SignatureStats verifier;  // outcomes of the signature checks
  uint32_t rejected_no_key = 0;      // frames rejected because SIGN_ENABLE is set without a key
  uint32_t provisioning_refused = 0; // SETUP_SIGNING received on the radio
  uint32_t clock_saves = 0;

  uint32_t rejected() const { return verifier.rejected() + rejected_no_key; }
};

class RadioSigning {
 public:
  static constexpr uint8_t kLinkId = 2;                         // the radio port's link id in signatures
  static constexpr uint32_t kClockSavePeriodUs = 30000000u;     // 30 s
  static constexpr uint64_t kBootJump = 30 * mavlink::kSigningTicksPerSecond;

  RadioSigning() : signer_(key_, clock_, kLinkId), verifier_(key_, clock_) {}
  RadioSigning(const RadioSigning&) = delete;
  RadioSigning& operator=(const RadioSigning&) = delete;

  // Reads the key and the clock from storage. False when a stored key record exists but is unreadable
  // (the radio then has no key).
  bool load(const StorageIo& io);

  // SIGN_ENABLE.
  void set_enabled(bool enabled);
  bool enabled() const { return enabled_; }
  bool has_key() const { return has_key_; }
  // Frames on the radio are signed and must be signed.
  bool active() const { return enabled_ && has_key_; }

  // A frame received on the radio: accepted or not (counted either way).
  mavlink::SignatureCheck check(const mavlink::Frame& frame);

  // Completes a frame for the radio whose payload mavlink::write_payload() put in `out`: signed when
  // active. The buffer must hold the untruncated signed frame (max_frame_length<Msg>(true)).
  size_t finish(mavlink::Sender& sender, uint32_t message_id, uint8_t crc_extra, size_t full_length, uint8_t* out) {
    return active() ? mavlink::finish_signed(sender, signer_, message_id, crc_extra, full_length, out)
                    : sender.finish(message_id, crc_extra, full_length, out);
  }

  enum class Provisioned : uint8_t { kKeySet, kSigningOff, kStorageFailed };
  // A SETUP_SIGNING received on the USB port: stores the key (an all-zero key and timestamp removes it),
  // moves the clock to its initial timestamp, forgets the streams heard under the old key.
  Provisioned provision(const StorageIo& io, const mavlink::SetupSigning& msg);
  // A SETUP_SIGNING received on the radio: refused and counted.
  void refuse_provisioning() { ++provisioning_refused_; }

  // Saves the clock when it moved since the last save and kClockSavePeriodUs passed (or now, with
  // `force`). Call only when a storage write may block (disarmed).
  void persist_clock(const StorageIo& io, uint32_t now_us, bool force);

  RadioSigningStats stats() const {
    RadioSigningStats s;
    s.verifier = verifier_.stats();
    s.rejected_no_key = rejected_no_key_;
    s.provisioning_refused = provisioning_refused_;
    s.clock_saves = clock_saves_;
    return s;
  }
  // stats().rejected() without assembling the whole record.
  uint32_t rejected() const { return verifier_.stats().rejected() + rejected_no_key_; }
  uint64_t clock() const { return clock_.now(); }

 private:
  bool save_clock(const StorageIo& io);

  mavlink::SigningKey key_{};
  mavlink::SigningClock clock_;
  mavlink::Signer signer_;
  mavlink::SignatureVerifier verifier_;
  bool enabled_ = false;
  bool has_key_ = false;
  uint64_t persisted_mark_ = 0;  // the clock at boot or at the last save
  bool save_started_ = false;
  uint32_t last_save_us_ = 0;
  // RadioSigningStats' own counters (its verifier part is the verifier's, not a second copy in RAM).
  uint32_t rejected_no_key_ = 0;
  uint32_t provisioning_refused_ = 0;
  uint32_t clock_saves_ = 0;
};

}  // namespace fw
}  // namespace quad
