// Where the firmware keeps its flight logs: a numbered sequence of logs, one per flight, each a byte stream
// written once from its start (the ULog writer, ulog_writer.h) and read back by the log download (MAVLink
// LOG_REQUEST_LIST / LOG_REQUEST_DATA, ground_link.h). A target provides one: on the host a directory of
// files, on the APM 2.5 its DataFlash chip (hal/avr/dataflash.cpp); a target without storage passes none.
//
// Plain function pointers over a context, like StorageIo: the core needs no virtual dispatch and a board
// links exactly the store it has.
#pragma once

#include <stdint.h>

namespace quad {
namespace fw {

struct LogEntry {
  uint32_t size_bytes;  // bytes written so far (the open log grows)
  uint32_t time_utc_s;  // when it was opened; 0 when the vehicle had no UTC time
};

struct LogStore {
  void* context;
  // Opens a new log after the newest one, closing any open one; false when the store is full or absent.
  bool (*open)(void* context, uint32_t time_utc_s);
  // Appends to the open log; returns how many bytes it took: fewer than length when the store is full
  // (the log ends there) or when the device is busy this instant (the caller keeps the rest for later).
  uint16_t (*append)(void* context, const uint8_t* data, uint16_t length);
  // Writes what is buffered and makes the log's index entry durable.
  void (*close)(void* context);
  // Logs held, the open one included. Log ids are 1..count, oldest first (MAVLink LOG_ENTRY.id).
  uint16_t (*count)(void* context);
  bool (*entry)(void* context, uint16_t id, LogEntry* out);
  // Copies up to length bytes of log id from offset; returns how many (0 past the end, or busy).
  uint16_t (*read)(void* context, uint16_t id, uint32_t offset, uint8_t* dst, uint16_t length);
  // Erases every log (LOG_ERASE); refused (false) while a log is open.
  bool (*erase_all)(void* context);
};

}  // namespace fw
}  // namespace quad
