// The ground link's log protocol (ground_link_logs.cpp) on the flight application in HIL, against a log
// store in memory: the list, a whole download with frames lost on the way and the missing ranges asked
// for again, the end of a log, erase, and a vehicle without a store.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <vector>

#include "app_bench.h"
#include "quad/firmware/log_store.h"

namespace {

namespace mav = quad::mavlink;
using quad::fw::test::Bench;

// Logs as vectors; erase refused while one is open, as the interface says.
struct MemoryStore {
  std::vector<std::vector<uint8_t>> logs;
  bool open = false;
  quad::fw::LogStore store{this, &MemoryStore::do_open, &MemoryStore::do_append, &MemoryStore::do_close,
                           &MemoryStore::do_count, &MemoryStore::do_entry, &MemoryStore::do_read,
                           &MemoryStore::do_erase};
  static MemoryStore* self(void* c) { return static_cast<MemoryStore*>(c); }
  static bool do_open(void* c, uint32_t) {
    self(c)->logs.emplace_back();
    self(c)->open = true;
    return true;
  }
  static uint16_t do_append(void* c, const uint8_t* d, uint16_t n) {
    self(c)->logs.back().insert(self(c)->logs.back().end(), d, d + n);
    return n;
  }
  static void do_close(void* c) { self(c)->open = false; }
  static uint16_t do_count(void* c) { return static_cast<uint16_t>(self(c)->logs.size()); }
  static bool do_entry(void* c, uint16_t id, quad::fw::LogEntry* e) {
    if (id == 0 || id > self(c)->logs.size()) return false;
    e->size_bytes = static_cast<uint32_t>(self(c)->logs[id - 1].size());
    e->time_utc_s = 1000u + id;
    return true;
  }
  static uint16_t do_read(void* c, uint16_t id, uint32_t ofs, uint8_t* dst, uint16_t n) {
    if (id == 0 || id > self(c)->logs.size()) return 0;
    const std::vector<uint8_t>& log = self(c)->logs[id - 1];
    if (ofs >= log.size()) return 0;
    const uint16_t got = static_cast<uint16_t>(std::min<size_t>(n, log.size() - ofs));
    std::copy(log.begin() + ofs, log.begin() + ofs + got, dst);
    return got;
  }
  static bool do_erase(void* c) {
    if (self(c)->open) return false;
    self(c)->logs.clear();
    return true;
  }
};

std::vector<uint8_t> random_log(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> v(n);
  for (auto& b : v) b = static_cast<uint8_t>(rng());
  return v;
}

template <class Msg>
Msg to_vehicle() {
  Msg m;
  m.target_system = 1;
  m.target_component = 1;
  return m;
}

TEST(LogDownload, NoStoreAnswersNoLogs) {
  Bench b;
  b.boot();
  b.send(quad::hal::kUart2, to_vehicle<mav::LogRequestList>(), b.gcs);
  ASSERT_EQ(b.log_entries.size(), 1u);
  EXPECT_EQ(b.log_entries[0].first, quad::hal::kUart2);
  EXPECT_EQ(b.log_entries[0].second.num_logs, 0);
  EXPECT_EQ(b.log_entries[0].second.id, 0);
}

TEST(LogDownload, ListsThenStreamsALogAndResumesLostRanges) {
  MemoryStore mem;
  mem.logs = {random_log(1000, 1), random_log(4321, 2)};
  Bench b;
  b.log_store = &mem.store;
  b.boot();
  mav::LogRequestList list = to_vehicle<mav::LogRequestList>();
  list.start = 0;
  list.end = 0xFFFF;
  b.send(quad::hal::kUart0, list, b.gcs);
  for (int i = 0; i < 20; ++i) b.still_step();
  ASSERT_EQ(b.log_entries.size(), 2u) << "one LOG_ENTRY per log, streamed";
  EXPECT_EQ(b.log_entries[1].second.id, 2);
  EXPECT_EQ(b.log_entries[1].second.size, 4321u);
  EXPECT_EQ(b.log_entries[1].second.num_logs, 2);
  EXPECT_EQ(b.log_entries[1].second.last_log_num, 2);
  EXPECT_EQ(b.log_entries[1].second.time_utc, 1002u);

  // The whole of log 2 on the radio; every fifth LOG_DATA is lost on the way.
  mav::LogRequestData req = to_vehicle<mav::LogRequestData>();
  req.id = 2;
  req.ofs = 0;
  req.count = 0xFFFFFFFF;
  b.send(quad::hal::kUart2, req, b.gcs);
  std::vector<uint8_t> got(4321, 0);
  std::map<uint32_t, uint32_t> have;  // ofs -> end
  size_t seen = 0, frames = 0;
  bool ended = false;
  auto take = [&]() {
    for (; seen < b.log_data.size(); ++seen) {
      const mav::LogData& d = b.log_data[seen].second;
      EXPECT_EQ(b.log_data[seen].first, quad::hal::kUart2) << "LOG_DATA on the port that asked";
      EXPECT_EQ(d.id, 2);
      if (d.count == 0) {
        ended = true;
        continue;
      }
      if (++frames % 5 == 0) continue;  // lost
      std::copy(d.data, d.data + d.count, got.begin() + d.ofs);
      have[d.ofs] = d.ofs + d.count;
    }
  };
  for (int i = 0; i < 400; ++i) {
    b.still_step();
    take();
  }
  EXPECT_TRUE(ended) << "a LOG_DATA with count 0 ends the stream";
  // Ask again for each missing range.
  for (int round = 0; round < 20; ++round) {
    uint32_t at = 0;
    for (const auto& r : have) {
      if (r.first > at) break;
      at = std::max(at, r.second);
    }
    if (at >= 4321) break;
    auto next = have.upper_bound(at);
    req.ofs = at;
    req.count = (next == have.end() ? 4321u : next->first) - at;
    b.send(quad::hal::kUart2, req, b.gcs);
    for (int i = 0; i < 100; ++i) {
      b.still_step();
      take();
    }
  }
  EXPECT_EQ(got, mem.logs[1]);
  // At most one log frame per iteration, and none while telemetry went out in the same one.
  EXPECT_LE(b.log_data.size(), 400u + 20u * 100u);
}

TEST(LogDownload, EraseEmptiesTheStoreAndRequestEndStopsTheStream) {
  MemoryStore mem;
  mem.logs = {random_log(20000, 3)};
  Bench b;
  b.log_store = &mem.store;
  b.boot();
  mav::LogRequestData req = to_vehicle<mav::LogRequestData>();
  req.id = 1;
  req.count = 0xFFFFFFFF;
  b.send(quad::hal::kUart0, req, b.gcs);
  for (int i = 0; i < 10; ++i) b.still_step();
  const size_t before = b.log_data.size();
  EXPECT_GT(before, 0u);
  b.send(quad::hal::kUart0, to_vehicle<mav::LogRequestEnd>(), b.gcs);
  for (int i = 0; i < 10; ++i) b.still_step();
  EXPECT_EQ(b.log_data.size(), before);

  mem.open = true;
  b.send(quad::hal::kUart0, to_vehicle<mav::LogErase>(), b.gcs);
  EXPECT_TRUE(b.said("logs: not erased, a log is open"));
  EXPECT_EQ(mem.logs.size(), 1u);
  mem.open = false;
  b.send(quad::hal::kUart0, to_vehicle<mav::LogErase>(), b.gcs);
  EXPECT_TRUE(mem.logs.empty());
  b.send(quad::hal::kUart0, to_vehicle<mav::LogRequestList>(), b.gcs);
  ASSERT_FALSE(b.log_entries.empty());
  EXPECT_EQ(b.log_entries.back().second.num_logs, 0);
}

}  // namespace
