#include "quad/firmware/ram_log_store.h"

namespace quad {
namespace fw {

void RamLogStore::init(uint8_t* region, uint32_t size) {
  region_ = region;
  capacity_ = size;
  count_ = 0;
  open_ = false;
  store_ = LogStore{this, open, append, close, count, entry, read, erase_all};
}

bool RamLogStore::open(void* context, uint32_t time_utc_s) {
  RamLogStore& s = self(context);
  s.open_ = false;
  const uint32_t start = s.count_ == 0 ? 0 : s.logs_[s.count_ - 1].start + s.logs_[s.count_ - 1].size;
  if (s.count_ == kMaxLogs || start >= s.capacity_) return false;
  s.logs_[s.count_] = Log{start, 0, time_utc_s};
  ++s.count_;
  s.open_ = true;
  return true;
}

uint16_t RamLogStore::append(void* context, const uint8_t* data, uint16_t length) {
  RamLogStore& s = self(context);
  if (!s.open_) return 0;
  Log& log = s.logs_[s.count_ - 1];
  const uint32_t end = log.start + log.size;
  const uint32_t room = s.capacity_ - end;
  const uint16_t take = room < length ? static_cast<uint16_t>(room) : length;
  for (uint16_t i = 0; i < take; ++i) s.region_[end + i] = data[i];
  log.size += take;
  return take;
}

bool RamLogStore::entry(void* context, uint16_t id, LogEntry* out) {
  const RamLogStore& s = self(context);
  if (id < 1 || id > s.count_) return false;
  out->size_bytes = s.logs_[id - 1].size;
  out->time_utc_s = s.logs_[id - 1].time_utc_s;
  return true;
}

uint16_t RamLogStore::read(void* context, uint16_t id, uint32_t offset, uint8_t* dst, uint16_t length) {
  const RamLogStore& s = self(context);
  if (id < 1 || id > s.count_ || offset >= s.logs_[id - 1].size) return 0;
  const Log& log = s.logs_[id - 1];
  const uint32_t left = log.size - offset;
  const uint16_t n = left < length ? static_cast<uint16_t>(left) : length;
  for (uint16_t i = 0; i < n; ++i) dst[i] = s.region_[log.start + offset + i];
  return n;
}

bool RamLogStore::erase_all(void* context) {
  RamLogStore& s = self(context);
  if (s.open_) return false;
  s.count_ = 0;
  return true;
}

}  // namespace fw
}  // namespace quad
