#include "quad/firmware/redundant_record.h"

#include "quad/link/crc.h"

namespace quad {
namespace fw {
namespace {

constexpr uint16_t kErased16 = 0xFFFF;
constexpr uint16_t kChunk = 16;  // bytes read at a time: stack, not RAM buffers the size of a slot

struct Trailer {
  uint16_t sequence;
  uint16_t tag;
  uint16_t crc;
};

// What one slot holds.
struct SlotState {
  bool readable = false;   // the device answered
  bool valid = false;      // CRC matches and the tag is ours
  bool foreign = false;    // CRC matches, another tag
  bool erased = false;     // trailer all 0xFF
  uint16_t sequence = 0;
};

uint16_t slot_offset(const RecordLayout& layout, uint8_t slot) {
  return static_cast<uint16_t>(layout.offset + slot * record_slot_size(layout.payload_size));
}

void put16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
uint16_t get16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }

SlotState inspect(const StorageIo& io, const RecordLayout& layout, uint8_t slot) {
  SlotState s;
  const uint16_t base = slot_offset(layout, slot);
  uint16_t crc = mavlink::kCrcInit;
  uint8_t chunk[kChunk];
  for (uint16_t done = 0; done < layout.payload_size;) {
    const uint16_t n = layout.payload_size - done < kChunk ? layout.payload_size - done : kChunk;
    if (!io.read(static_cast<uint16_t>(base + done), chunk, n)) return s;
    crc = mavlink::crc_accumulate(chunk, n, crc);
    done = static_cast<uint16_t>(done + n);
  }
  uint8_t trailer[kRecordOverhead];
  if (!io.read(static_cast<uint16_t>(base + layout.payload_size), trailer, sizeof trailer)) return s;
  s.readable = true;
  crc = mavlink::crc_accumulate(trailer, 4, crc);
  const Trailer t{get16(trailer), get16(trailer + 2), get16(trailer + 4)};
  s.erased = t.sequence == kErased16 && t.tag == kErased16 && t.crc == kErased16;
  if (crc != t.crc) return s;
  s.valid = t.tag == layout.tag;
  s.foreign = !s.valid;
  s.sequence = t.sequence;
  return s;
}

// a was written after b (serial-number arithmetic: the counter may wrap).
bool newer(uint16_t a, uint16_t b) { return static_cast<int16_t>(static_cast<uint16_t>(a - b)) > 0; }

// Writes src[0 .. n) at offset, skipping the bytes the storage already holds.
bool write_changed(const StorageIo& io, uint16_t offset, const uint8_t* src, uint16_t n) {
  uint8_t chunk[kChunk];
  for (uint16_t done = 0; done < n;) {
    const uint16_t len = n - done < kChunk ? n - done : kChunk;
    if (!io.read(static_cast<uint16_t>(offset + done), chunk, len)) return false;
    // Each run of differing bytes is one write.
    uint16_t i = 0;
    while (i < len) {
      if (chunk[i] == src[done + i]) {
        ++i;
        continue;
      }
      uint16_t end = i + 1;
      while (end < len && chunk[end] != src[done + end]) ++end;
      if (!io.write(static_cast<uint16_t>(offset + done + i), src + done + i, static_cast<uint16_t>(end - i))) return false;
      i = end;
    }
    done = static_cast<uint16_t>(done + len);
  }
  return true;
}

}  // namespace

RecordStatus record_load(const StorageIo& io, const RecordLayout& layout, void* payload) {
  const SlotState s0 = inspect(io, layout, 0);
  const SlotState s1 = inspect(io, layout, 1);
  if (!s0.readable || !s1.readable) return RecordStatus::kIoError;
  if (!s0.valid && !s1.valid) {
    if (s0.foreign || s1.foreign) return RecordStatus::kTagMismatch;
    if (s0.erased && s1.erased) return RecordStatus::kEmpty;
    return RecordStatus::kCorrupt;
  }
  const uint8_t newest = !s1.valid || (s0.valid && newer(s0.sequence, s1.sequence)) ? 0 : 1;
  if (!io.read(slot_offset(layout, newest), payload, layout.payload_size)) return RecordStatus::kIoError;
  return RecordStatus::kLoaded;
}

bool record_save(const StorageIo& io, const RecordLayout& layout, const void* payload) {
  const SlotState s0 = inspect(io, layout, 0);
  const SlotState s1 = inspect(io, layout, 1);
  if (!s0.readable || !s1.readable) return false;
  // The target is the slot without the newest valid copy; its sequence follows the newest one.
  uint8_t target = 0;
  uint16_t sequence = 0;
  if (s0.valid && (!s1.valid || newer(s0.sequence, s1.sequence))) {
    target = 1;
    sequence = static_cast<uint16_t>(s0.sequence + 1);
  } else if (s1.valid) {
    target = 0;
    sequence = static_cast<uint16_t>(s1.sequence + 1);
  }
  const uint8_t* bytes = static_cast<const uint8_t*>(payload);
  uint8_t trailer[kRecordOverhead];
  put16(trailer, sequence);
  put16(trailer + 2, layout.tag);
  const uint16_t crc = mavlink::crc_accumulate(trailer, 4, mavlink::crc_accumulate(bytes, layout.payload_size, mavlink::kCrcInit));
  put16(trailer + 4, crc);
  const uint16_t base = slot_offset(layout, target);
  // Payload, then sequence and tag, then the CRC: until the last CRC byte lands the slot is invalid.
  return write_changed(io, base, bytes, layout.payload_size) &&
         write_changed(io, static_cast<uint16_t>(base + layout.payload_size), trailer, 4) &&
         write_changed(io, static_cast<uint16_t>(base + layout.payload_size + 4), trailer + 4, 2);
}

}  // namespace fw
}  // namespace quad
