// The host's log store (quad/firmware/log_store.h): a directory of files DIR/log_NNN.ulg, one per log.
// The logs are the files present, oldest (lowest number) first, with ids 1..N; a new log is the next
// number after the highest. The flight log writes into it, and the log download serves its files.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "quad/firmware/log_store.h"

namespace quad::fw {

class LogDirectory {
 public:
  LogDirectory();
  ~LogDirectory();
  LogDirectory(const LogDirectory&) = delete;
  LogDirectory& operator=(const LogDirectory&) = delete;

  // Takes dir (created when missing) and the logs in it; false with the reason in *error.
  bool attach(const std::string& dir, std::string* error);
  const LogStore* store() const { return &store_; }

  // The file of log id (1..count), or empty.
  std::string path(uint16_t id) const;
  uint16_t count() const { return static_cast<uint16_t>(logs_.size()); }

 private:
  struct Log {
    unsigned number;     // NNN of log_NNN.ulg
    uint32_t time_utc_s; // given to open(); 0 for the files found in the directory
  };
  bool open_log(uint32_t time_utc_s);
  uint16_t append(const uint8_t* data, uint16_t length);
  void close_log();
  bool entry(uint16_t id, LogEntry* out);
  uint16_t read(uint16_t id, uint32_t offset, uint8_t* dst, uint16_t length);
  bool erase_all();

  std::string dir_;
  std::vector<Log> logs_;
  std::FILE* writing_ = nullptr;  // the open log (the last of logs_)
  std::vector<char> write_buffer_;
  std::FILE* reading_ = nullptr;  // the log last read, kept open between reads
  uint16_t reading_id_ = 0;
  LogStore store_;
};

}  // namespace quad::fw
