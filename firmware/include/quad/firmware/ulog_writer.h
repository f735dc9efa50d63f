// A PX4 ULog writer (https://docs.px4.io/main/en/dev_log/ulog_file_format.html, version 1, little-endian)
// over a LogStore (log_store.h): the file header, the flag bits, formats, information, parameters,
// add_logged, data and logged strings, as whole records.
//
// It owns one staging buffer and no other storage. A record is composed in the buffer and waits there
// until flush() (commit() flushes at once), or until a record behind it needs its room: the records of
// a control iteration go to the store in one append, and flush(max_bytes) hands the store no more than
// an iteration has time for, the rest waiting in the buffer for a later iteration. What the store does not take at once (busy) stays in the buffer
// and goes first on the next call, so the stream never loses part of a record. A record that finds no
// room behind the pending bytes is dropped whole and counted (dropped()), and the next record that fits
// is preceded by a dropout message (ULog 'O', dropout()) that says how long the gap was. A format record
// is longer than a data record: its text stays in flash and is copied in behind the buffer as the store
// drains it, and no other record is queued until it has all gone.
//
// All three targets are little-endian with IEEE-754 floats, so a field's bytes are its memory image.
#pragma once

#include <stdint.h>
#include <string.h>

#include "quad/firmware/flash.h"
#include "quad/firmware/log_store.h"

namespace quad {
namespace fw {

namespace ulog {
// Message types.
constexpr uint8_t kFlagBits = 'B';
constexpr uint8_t kFormat = 'F';
constexpr uint8_t kInfo = 'I';
constexpr uint8_t kParameter = 'P';
constexpr uint8_t kAddLogged = 'A';
constexpr uint8_t kData = 'D';
constexpr uint8_t kLogging = 'L';
constexpr uint8_t kDropout = 'O';

constexpr uint8_t kFileHeaderBytes = 16;   // "ULog" 01 12 35, version, uint64 timestamp
constexpr uint8_t kMessageHeaderBytes = 3;  // uint16 msg_size (payload), uint8 msg_type
constexpr uint8_t kFlagBitsPayload = 40;    // compat[8], incompat[8], appended_offsets[3] (uint64)
constexpr uint8_t kDataHeaderBytes = kMessageHeaderBytes + 2;  // and the uint16 msg_id

// Bytes a data record of a topic whose fields take `fields` bytes occupies in the file.
constexpr uint8_t data_record_bytes(uint8_t fields) { return static_cast<uint8_t>(kDataHeaderBytes + fields); }
}  // namespace ulog

// Fills a data record's fields in order (a cursor into the staging buffer). Out of line: one copy of each
// on the AVR rather than a memcpy per field of every record.
class UlogFields {
 public:
  explicit UlogFields(uint8_t* p) : p_(p) {}
  UlogFields& u8(uint8_t v);
  UlogFields& u32(uint32_t v);
  UlogFields& u64(uint64_t v);
  UlogFields& f32(float v);
  UlogFields& f32(const float* v, uint8_t n);
  UlogFields& bytes(const void* v, uint8_t n);

 private:
  uint8_t* p_;
};

class UlogWriter {
 public:
  // The records of nearly two control iterations: the flight log's largest (sensor_combined,
  // vehicle_attitude, sensor_mag, vehicle_local_position, the setpoint and actuator_motors) take 239
  // bytes, and an iteration without time for the store leaves its records to the next
  // (BackgroundBudget). No more fits the ATmega2560's 8 KiB beside the stack (docs/targets.md, "Memory").
  static constexpr uint16_t kStagingBytes = 448;

  // store: where the log goes; null, or a store without open(), means nowhere (every open() fails).
  void attach(const LogStore* store) { store_ = store; }
  bool has_store() const { return store_ != nullptr && store_->open != nullptr && store_->append != nullptr; }

  // Opens a new log in the store and queues the file header (timestamp_us: the vehicle clock) and the
  // flag bits. False when there is no store or it refused.
  bool open(uint64_t timestamp_us, uint32_t time_utc_s);
  // Hands what it can of the pending bytes to the store, and closes the log (the rest is lost).
  void close();
  bool is_open() const { return open_; }

  // Definitions (before the first add_logged) and data. Each queues one whole record and returns true,
  // or queues nothing and counts a drop.
  bool format(FlashText format);                   // "name:type field;type field;..."
  bool format(FlashText format, uint16_t length);  // the same, its length known
  bool add_logged(uint16_t msg_id, FlashText format);  // the name is format's text before ':'
  bool info(FlashText name, FlashText value);      // key "char[N] name"
  bool info(FlashText name, uint32_t value);       // key "uint32_t name"
  bool parameter(const char* name, float value);   // key "float NAME"
  bool logged_string(uint8_t level, uint64_t timestamp_us, const char* text, uint8_t length);
  // A data record of `size` field bytes: returns the cursor for its fields, or null (dropped). The
  // caller writes exactly `size` bytes; the record goes to the store with the next flush() or commit().
  uint8_t* begin_data(uint16_t msg_id, uint8_t size);
  void commit() { flush(); }  // the queued records to the store now

  // Hands pending bytes to the store, at most max_bytes of them; true when nothing is left.
  bool flush(uint16_t max_bytes = 0xFFFFu);
  // A dropout message (duration_ms: how long records were lost), queued like a record.
  bool dropout(uint16_t duration_ms);
  // How many bytes a record that finds the buffer full may hand to the store to make its room (a control
  // iteration without time left: few or none, and the record is dropped); 0xFFFF by default.
  void set_room_flush_limit(uint16_t max_bytes) { room_flush_limit_ = max_bytes; }
  bool idle() const { return head_ == tail_ && flash_left_ == 0; }
  uint16_t pending() const { return static_cast<uint16_t>(tail_ - head_ + flash_left_); }
  uint32_t dropped() const { return dropped_; }
  // A record the caller gave up without composing it: counted like a drop (a dropout message follows).
  void count_drop() { ++dropped_; }

 private:
  // An information or parameter record: the key ("type name", key_length bytes), then the value.
  bool key_value(uint8_t type, const uint8_t* key, uint8_t key_length, const void* value, uint8_t size);
  // Room for a record of `in_buffer` bytes after the message header; the header is written with
  // msg_size = payload. Null (and a drop counted) when there is none.
  uint8_t* reserve(uint8_t type, uint16_t payload, uint8_t in_buffer);
  // Moves the pending bytes to the front of the buffer.
  void compact();

  static constexpr uint8_t kCloseAttempts = 64;  // flush() calls close() makes at most

  const LogStore* store_ = nullptr;
  uint8_t buffer_[kStagingBytes];
  uint16_t head_ = 0;  // the first byte the store has not taken
  uint16_t tail_ = 0;  // the end of the queued bytes
  const char* flash_rest_ = nullptr;  // what remains of a format's text in flash, after the buffer
  uint16_t flash_left_ = 0;
  uint32_t dropped_ = 0;
  uint16_t room_flush_limit_ = 0xFFFFu;
  bool open_ = false;
};

// Length of a text in flash.
uint16_t flash_length(FlashText text);

}  // namespace fw
}  // namespace quad
