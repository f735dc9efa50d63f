// CRC-16/MCRF4XX (the "X.25" checksum of MAVLink): polynomial 0x1021 reflected, initial value 0xFFFF,
// no final XOR. MAVLink v2 runs it over the frame from the length byte to the end of the payload, then
// over the message's CRC_EXTRA byte (a hash of its definition, so peers with different definitions of
// the same id reject each other's frames).
#pragma once

#include <stddef.h>
#include <stdint.h>

#if defined(__AVR__)
#include <util/crc16.h>  // avr-libc: the same CRC in hand-written assembly, twice as fast as the C form
#endif

namespace quad {
namespace mavlink {

constexpr uint16_t kCrcInit = 0xFFFF;

// The byte-wise form from the MAVLink C library (no table: 512 bytes of table would cost SRAM on the AVR).
// On the AVR, avr-libc's _crc_ccitt_update computes the same function (reflected CCITT polynomial, no
// final XOR) in 26 instead of 52 cycles per byte (measured on simavr).
inline uint16_t crc_accumulate(uint8_t byte, uint16_t crc) {
#if defined(__AVR__)
  return _crc_ccitt_update(crc, byte);
#else
  uint8_t tmp = static_cast<uint8_t>(byte ^ static_cast<uint8_t>(crc & 0xFF));
  tmp = static_cast<uint8_t>(tmp ^ static_cast<uint8_t>(tmp << 4));
  return static_cast<uint16_t>((crc >> 8) ^ (static_cast<uint16_t>(tmp) << 8) ^
                               (static_cast<uint16_t>(tmp) << 3) ^ (tmp >> 4));
#endif
}

inline uint16_t crc_accumulate(const uint8_t* data, size_t length, uint16_t crc) {
  for (size_t i = 0; i < length; ++i) crc = crc_accumulate(data[i], crc);
  return crc;
}

}  // namespace mavlink
}  // namespace quad
