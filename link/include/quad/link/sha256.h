// SHA-256 (NIST FIPS 180-4), freestanding: the hash under MAVLink v2 message signing (signing.h).
//
// Incremental: update() any number of times, then finish(). The state is 105 bytes on the AVR and the
// compression uses a rolling 16-word message schedule (64 bytes of stack instead of 256), so it fits the
// AVR's SRAM; the round constants live in flash there. No heap, no C++ library.
//
//   quad::mavlink::Sha256 hash;
//   hash.update(key, 32);
//   hash.update(frame, n);
//   uint8_t digest[quad::mavlink::kSha256DigestLength];
//   hash.finish(digest);
#pragma once

#include <stddef.h>
#include <stdint.h>

namespace quad {
namespace mavlink {

constexpr size_t kSha256DigestLength = 32;
constexpr size_t kSha256BlockLength = 64;

class Sha256 {
 public:
  Sha256() { reset(); }

  // Starts a new message (finish() leaves the object ready for reuse through this).
  void reset();

  void update(const uint8_t* data, size_t length);

  // Pads, writes the 32-byte digest to `digest` and resets. `digest_length` < 32 writes only the
  // leading bytes of the digest (MAVLink keeps 6).
  void finish(uint8_t* digest, size_t digest_length = kSha256DigestLength);

 private:
  void compress(const uint8_t* block);

  uint32_t state_[8];
  uint64_t message_bits_;  // FIPS 180-4 allows messages up to 2^64 - 1 bits
  uint8_t block_[kSha256BlockLength];
  uint8_t block_fill_;
};

// The digest of one buffer.
void sha256(const uint8_t* data, size_t length, uint8_t digest[kSha256DigestLength]);

}  // namespace mavlink
}  // namespace quad
