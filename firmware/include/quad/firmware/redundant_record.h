// A record kept in two copies ("slots") in persistent storage, so that power lost in the middle of a
// write never loses it: the write goes to the slot that does not hold the newest valid copy, so the
// newest complete record survives whatever byte the write stopped at.
//
// Slot layout (little-endian): payload (n bytes) | sequence (2) | tag (2) | CRC (2)
//   sequence: one more than the other slot's at every save (16-bit serial-number arithmetic);
//   tag:      what the payload is (record kind, layout, schema), so another firmware's record is not read;
//   CRC:      CRC-16/MCRF4XX over payload, sequence and tag, written last.
// Load takes the valid slot with the newer sequence. A save rewrites only the bytes that differ from
// what the target slot holds (an AVR EEPROM byte takes 3.3 ms to write and wears out after ~100 000
// writes), and the CRC last, so an interrupted save leaves that slot invalid, never valid and mixed
// (up to the CRC's 2^-16 chance of accepting a damaged slot).
#pragma once

#include <stdint.h>

namespace quad {
namespace fw {

// Storage access through two functions, so the same code serves the AVR EEPROM, the host file and the
// tests. Both return false when the range lies outside the storage or the device fails.
struct StorageIo {
  bool (*read)(uint16_t offset, void* dst, uint16_t length);
  bool (*write)(uint16_t offset, const void* src, uint16_t length);
};

struct RecordLayout {
  uint16_t offset;        // of slot 0; slot 1 follows it
  uint16_t payload_size;
  uint16_t tag;
};

constexpr uint16_t kRecordOverhead = 6;  // sequence, tag, CRC
constexpr uint16_t record_slot_size(uint16_t payload_size) { return payload_size + kRecordOverhead; }
constexpr uint16_t record_footprint(uint16_t payload_size) { return 2 * record_slot_size(payload_size); }

enum class RecordStatus : uint8_t {
  kLoaded,       // the newest valid copy was read
  kEmpty,        // both slots erased (first boot)
  kTagMismatch,  // a complete record of another kind or layout (another firmware), none of ours
  kCorrupt,      // neither slot holds a valid record
  kIoError,      // the storage could not be read
};

// Reads the newest valid copy into payload[0 .. payload_size). The payload is left unspecified unless
// the result is kLoaded.
RecordStatus record_load(const StorageIo& io, const RecordLayout& layout, void* payload);

// Writes payload[0 .. payload_size) into the slot that does not hold the newest valid copy, with the
// next sequence number. False when the storage failed (the newest valid copy is then unchanged).
bool record_save(const StorageIo& io, const RecordLayout& layout, const void* payload);

}  // namespace fw
}  // namespace quad
