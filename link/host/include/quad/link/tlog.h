// The link record (.tlog): the format MAVProxy, QGroundControl and Mission Planner write and pymavlink's
// mavlogfile, MAVExplorer and node-mavlink's MavLinkTLogPacketSplitter read. Each record is an 8-byte
// big-endian time stamp (microseconds since the Unix epoch) followed by one whole MAVLink frame, the
// frame's bytes as they crossed the link. Host only (C++17): the ground side of a link, not the vehicle.
//
//   quad::tlog::TlogWriter file("link.tlog");            // throws std::runtime_error naming the file
//   quad::tlog::TlogStream from_vehicle(file), to_vehicle(file);
//   from_vehicle.feed(bytes, n, quad::tlog::unix_micros_now());  // any split: frames are reassembled
//
// A TlogStream is one direction of a link: it reassembles frames from reads of any size with the
// codec's Parser (dialect_message_info: the codec's messages and the project's), so every record is one
// frame whose CRC the codec has checked. Bytes of frames the codec does not know (no CRC_EXTRA to check
// them with) and damaged frames are not recorded; the stream counts them. The two directions need a
// stream each: bytes of one direction must never be fed between the bytes of a frame of the other.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

#include "quad/link/dialect.h"
#include "quad/link/parser.h"

namespace quad::tlog {

// The wall clock in microseconds since the Unix epoch.
uint64_t unix_micros_now();

class TlogWriter {
 public:
  // Creates (truncates) the file; throws std::runtime_error("PATH: cannot create: REASON").
  explicit TlogWriter(const std::string& path);
  ~TlogWriter();
  TlogWriter(const TlogWriter&) = delete;
  TlogWriter& operator=(const TlogWriter&) = delete;

  // One record. Time stamps never go back in the file: a record stamped before the one written last
  // takes that one's time (two sources of one link, e.g. a simulator's uplink and downlink, may be
  // handled a step out of order). Throws std::runtime_error naming the file when the write fails.
  void write(uint64_t unix_us, const uint8_t* frame, size_t size);
  // Pushes the buffered records to the file (they are also flushed every second of time stamps).
  void flush();

  const std::string& path() const { return path_; }
  uint64_t records() const { return records_; }
  uint64_t last_time_us() const { return last_us_; }

 private:
  std::string path_;
  std::FILE* file_ = nullptr;
  uint64_t records_ = 0;
  uint64_t last_us_ = 0;
  uint64_t flushed_us_ = 0;
};

class TlogStream {
 public:
  explicit TlogStream(TlogWriter& writer) : writer_(writer), parser_(mavlink::dialect_message_info) {}

  // Bytes of this direction as read or written, with the time they crossed; every frame they complete
  // becomes one record stamped with this time.
  void feed(const uint8_t* data, size_t size, uint64_t unix_us);

  const mavlink::ParserStats& stats() const { return parser_.stats(); }

 private:
  TlogWriter& writer_;
  mavlink::Parser parser_;
};

}  // namespace quad::tlog
