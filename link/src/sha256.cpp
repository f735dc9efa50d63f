// SHA-256 after NIST FIPS 180-4, section 6.2 (hash computation) and 5.1.1 (padding).
#include "quad/link/sha256.h"

#include <string.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>  // the 256-byte constant table stays in flash instead of the 8 KiB SRAM
#endif

namespace quad {
namespace mavlink {

namespace {

// FIPS 180-4 section 4.2.2: the first 32 bits of the fractional parts of the cube roots of the first
// 64 primes.
#if defined(__AVR__)
const uint32_t kRound[64] PROGMEM = {
#else
const uint32_t kRound[64] = {
#endif
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2,
};

inline uint32_t round_constant(uint8_t t) {
#if defined(__AVR__)
  return pgm_read_dword(&kRound[t]);
#else
  return kRound[t];
#endif
}

#if defined(__AVR__)
// The 8-bit AVR shifts a 32-bit word by a constant N with a loop of N one-bit steps (6 cycles each), which
// made the rotations most of SHA-256's cost. A rotation by whole bytes is register moves and a one-bit
// rotation six instructions, so each rotation is composed of the nearest whole-byte rotation and at most
// four one-bit rotations (189 000 -> 54 600 cycles per block, measured by link_avr_cycles).
#define QUAD_SHA256_INLINE inline __attribute__((always_inline))
QUAD_SHA256_INLINE uint32_t rotr1(uint32_t x) { return (x >> 1) | (x << 31); }
QUAD_SHA256_INLINE uint32_t rotl1(uint32_t x) { return (x << 1) | (x >> 31); }

// Rotates right by Bits in [-4, 4] one bit at a time (left when negative), unrolled at compile time.
template <int Bits, bool Right = (Bits > 0)>
struct BitRotation;
template <>
struct BitRotation<0, false> {
  static QUAD_SHA256_INLINE uint32_t apply(uint32_t x) { return x; }
};
template <int Bits>
struct BitRotation<Bits, true> {
  static QUAD_SHA256_INLINE uint32_t apply(uint32_t x) { return BitRotation<Bits - 1>::apply(rotr1(x)); }
};
template <int Bits>
struct BitRotation<Bits, false> {
  static QUAD_SHA256_INLINE uint32_t apply(uint32_t x) { return BitRotation<Bits + 1>::apply(rotl1(x)); }
};

template <unsigned N>
QUAD_SHA256_INLINE uint32_t rotr(uint32_t x) {
  constexpr unsigned kBytes = ((N + 4) / 8) % 4;  // the nearest whole-byte rotation
  const uint32_t by_bytes = kBytes == 0 ? x : (x >> (8 * kBytes)) | (x << (32 - 8 * kBytes));
  return BitRotation<static_cast<int>(N) - static_cast<int>(8 * ((N + 4) / 8))>::apply(by_bytes);
}
// x >> N as a rotation with the wrapped-around bits masked off.
template <unsigned N>
QUAD_SHA256_INLINE uint32_t shr(uint32_t x) {
  return rotr<N>(x) & (0xFFFFFFFFu >> N);
}
#else
#define QUAD_SHA256_INLINE inline
template <unsigned N>
inline uint32_t rotr(uint32_t x) {
  return (x >> N) | (x << (32 - N));
}
template <unsigned N>
inline uint32_t shr(uint32_t x) {
  return x >> N;
}
#endif

// FIPS 180-4 section 4.1.2, functions (4.2) to (4.7).
QUAD_SHA256_INLINE uint32_t ch(uint32_t x, uint32_t y, uint32_t z) { return (x & y) ^ (~x & z); }
QUAD_SHA256_INLINE uint32_t maj(uint32_t x, uint32_t y, uint32_t z) { return (x & y) ^ (x & z) ^ (y & z); }
QUAD_SHA256_INLINE uint32_t big_sigma0(uint32_t x) { return rotr<2>(x) ^ rotr<13>(x) ^ rotr<22>(x); }
QUAD_SHA256_INLINE uint32_t big_sigma1(uint32_t x) { return rotr<6>(x) ^ rotr<11>(x) ^ rotr<25>(x); }
QUAD_SHA256_INLINE uint32_t small_sigma0(uint32_t x) { return rotr<7>(x) ^ rotr<18>(x) ^ shr<3>(x); }
QUAD_SHA256_INLINE uint32_t small_sigma1(uint32_t x) { return rotr<17>(x) ^ rotr<19>(x) ^ shr<10>(x); }

inline uint32_t load_be32(const uint8_t* p) {
  return (static_cast<uint32_t>(p[0]) << 24) | (static_cast<uint32_t>(p[1]) << 16) |
         (static_cast<uint32_t>(p[2]) << 8) | static_cast<uint32_t>(p[3]);
}

inline void store_be32(uint32_t v, uint8_t* p) {
  p[0] = static_cast<uint8_t>(v >> 24);
  p[1] = static_cast<uint8_t>(v >> 16);
  p[2] = static_cast<uint8_t>(v >> 8);
  p[3] = static_cast<uint8_t>(v);
}

// W_t of FIPS 180-4 section 6.2.2 step 1 in a ring of 16 words: W_t for t >= 16 needs only W_{t-2},
// W_{t-7}, W_{t-15} and W_{t-16}, and W_{t-16} is the slot it overwrites.
QUAD_SHA256_INLINE uint32_t schedule(uint32_t* w, uint8_t t) {
  uint32_t& wt = w[t & 15];
  if (t >= 16) wt += small_sigma1(w[(t - 2) & 15]) + w[(t - 7) & 15] + small_sigma0(w[(t - 15) & 15]);
  return wt;
}

// One round of section 6.2.2 step 3. The working variables a..h live in v[8] and change roles instead of
// places: in round t, a is v[(8 - t) mod 8], b the next slot, and so on, so a round writes only the new
// e (into d's slot) and the new a (into h's slot) instead of moving all eight down by one (28 word moves
// per round on the AVR). One round in a loop, not eight unrolled ones: on the AVR the unrolled rounds
// cost 7 kB of flash for a fifth of the cycles, and the APM 2.5 image has no flash to spare.
inline void sha_round(uint32_t* v, uint8_t t, uint32_t k_plus_w) {
  const uint8_t r = static_cast<uint8_t>(8u - (t & 7u));
  uint32_t& a = v[r & 7u];
  uint32_t& d = v[(r + 3u) & 7u];
  uint32_t& e = v[(r + 4u) & 7u];
  uint32_t& h = v[(r + 7u) & 7u];
  const uint32_t t1 = h + big_sigma1(e) + ch(e, v[(r + 5u) & 7u], v[(r + 6u) & 7u]) + k_plus_w;
  d += t1;
  h = t1 + big_sigma0(a) + maj(a, v[(r + 1u) & 7u], v[(r + 2u) & 7u]);
}

}  // namespace

void Sha256::reset() {
  // FIPS 180-4 section 5.3.3: the initial hash value H(0).
  state_[0] = 0x6a09e667;
  state_[1] = 0xbb67ae85;
  state_[2] = 0x3c6ef372;
  state_[3] = 0xa54ff53a;
  state_[4] = 0x510e527f;
  state_[5] = 0x9b05688c;
  state_[6] = 0x1f83d9ab;
  state_[7] = 0x5be0cd19;
  message_bits_ = 0;
  block_fill_ = 0;
}

// FIPS 180-4 section 6.2.2.
void Sha256::compress(const uint8_t* block) {
  uint32_t w[16];
  for (uint8_t t = 0; t < 16; ++t) w[t] = load_be32(block + 4 * t);

  uint32_t v[8];
  memcpy(v, state_, sizeof v);
  for (uint8_t t = 0; t < 64; ++t) sha_round(v, t, round_constant(t) + schedule(w, t));
  for (uint8_t i = 0; i < 8; ++i) state_[i] += v[i];  // after 64 rounds the roles are back in place
}

void Sha256::update(const uint8_t* data, size_t length) {
  message_bits_ += static_cast<uint64_t>(length) * 8u;
  while (length > 0) {
    if (block_fill_ == 0 && length >= kSha256BlockLength) {  // whole blocks straight from the input
      compress(data);
      data += kSha256BlockLength;
      length -= kSha256BlockLength;
      continue;
    }
    size_t take = kSha256BlockLength - block_fill_;
    if (take > length) take = length;
    memcpy(block_ + block_fill_, data, take);
    block_fill_ = static_cast<uint8_t>(block_fill_ + take);
    data += take;
    length -= take;
    if (block_fill_ == kSha256BlockLength) {
      compress(block_);
      block_fill_ = 0;
    }
  }
}

// FIPS 180-4 section 5.1.1: append bit 1, zeros up to 56 mod 64 bytes, then the length in bits as a
// 64-bit big-endian number.
void Sha256::finish(uint8_t* digest, size_t digest_length) {
  const uint64_t bits = message_bits_;
  block_[block_fill_++] = 0x80;
  if (block_fill_ > kSha256BlockLength - 8) {
    memset(block_ + block_fill_, 0, kSha256BlockLength - block_fill_);
    compress(block_);
    block_fill_ = 0;
  }
  memset(block_ + block_fill_, 0, kSha256BlockLength - 8 - block_fill_);
  store_be32(static_cast<uint32_t>(bits >> 32), block_ + kSha256BlockLength - 8);
  store_be32(static_cast<uint32_t>(bits), block_ + kSha256BlockLength - 4);
  compress(block_);

  uint8_t word[4];
  if (digest_length > kSha256DigestLength) digest_length = kSha256DigestLength;
  for (size_t i = 0; i < digest_length; i += 4) {
    store_be32(state_[i / 4], word);
    memcpy(digest + i, word, digest_length - i < 4 ? digest_length - i : 4);
  }
  reset();
}

void sha256(const uint8_t* data, size_t length, uint8_t digest[kSha256DigestLength]) {
  Sha256 hash;
  hash.update(data, length);
  hash.finish(digest);
}

}  // namespace mavlink
}  // namespace quad
