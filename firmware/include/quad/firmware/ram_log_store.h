// A LogStore in a region of RAM, for a board with no non-volatile memory to spare for logs (QEMU's
// mps2-an386: its 4 MiB of RAM, no writable flash). It holds the flights since power-on and serves them to
// the log download until reset. Logs lie one after another in the region; when it is full the open log
// ends there and no new one opens (no wrap-around, unlike the DataFlash's ring: the logs last only until
// reset, so none needs room made by dropping an older one).
#pragma once

#include <stdint.h>

#include "quad/firmware/log_store.h"

namespace quad {
namespace fw {

class RamLogStore {
 public:
  static constexpr uint8_t kMaxLogs = 16;

  // region: size bytes of RAM owned by the store from now on; every log is forgotten.
  void init(uint8_t* region, uint32_t size);
  const LogStore& store() const { return store_; }

 private:
  struct Log {
    uint32_t start;
    uint32_t size;
    uint32_t time_utc_s;
  };
  static RamLogStore& self(void* context) { return *static_cast<RamLogStore*>(context); }
  static bool open(void* context, uint32_t time_utc_s);
  static uint16_t append(void* context, const uint8_t* data, uint16_t length);
  static void close(void* context) { self(context).open_ = false; }
  static uint16_t count(void* context) { return self(context).count_; }
  static bool entry(void* context, uint16_t id, LogEntry* out);
  static uint16_t read(void* context, uint16_t id, uint32_t offset, uint8_t* dst, uint16_t length);
  static bool erase_all(void* context);

  uint8_t* region_ = nullptr;
  uint32_t capacity_ = 0;
  Log logs_[kMaxLogs] = {};
  uint8_t count_ = 0;
  bool open_ = false;
  LogStore store_ = {};
};

}  // namespace fw
}  // namespace quad
