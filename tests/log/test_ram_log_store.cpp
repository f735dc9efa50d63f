// The RAM log store of the boards without log memory (ram_log_store.h): logs one after another, read back
// as written, the region's end ends the open log and refuses a new one, erase refused while one is open.
#include <gtest/gtest.h>

#include <vector>

#include "quad/firmware/ram_log_store.h"

namespace {

using quad::fw::LogEntry;
using quad::fw::LogStore;
using quad::fw::RamLogStore;

std::vector<uint8_t> pattern(size_t n, uint8_t seed) {
  std::vector<uint8_t> v(n);
  for (size_t i = 0; i < n; ++i) v[i] = static_cast<uint8_t>(seed + 7 * i);
  return v;
}

std::vector<uint8_t> read_all(const LogStore& s, uint16_t id, uint16_t chunk) {
  std::vector<uint8_t> out;
  uint8_t buf[256];
  for (uint16_t n; (n = s.read(s.context, id, static_cast<uint32_t>(out.size()), buf, chunk)) > 0;)
    out.insert(out.end(), buf, buf + n);
  return out;
}

TEST(RamLogStore, LogsReadBackAsWrittenOneAfterAnother) {
  std::vector<uint8_t> region(10000);
  RamLogStore ram;
  ram.init(region.data(), static_cast<uint32_t>(region.size()));
  const LogStore& s = ram.store();
  EXPECT_EQ(s.count(s.context), 0);
  const auto a = pattern(3000, 1), b = pattern(2500, 9);
  ASSERT_TRUE(s.open(s.context, 111));
  EXPECT_EQ(s.append(s.context, a.data(), 1000), 1000);
  EXPECT_EQ(s.append(s.context, a.data() + 1000, 2000), 2000);
  s.close(s.context);
  ASSERT_TRUE(s.open(s.context, 222));
  EXPECT_EQ(s.append(s.context, b.data(), 2500), 2500);
  s.close(s.context);
  ASSERT_EQ(s.count(s.context), 2);
  LogEntry e{};
  ASSERT_TRUE(s.entry(s.context, 2, &e));
  EXPECT_EQ(e.size_bytes, 2500u);
  EXPECT_EQ(e.time_utc_s, 222u);
  EXPECT_FALSE(s.entry(s.context, 3, &e));
  EXPECT_FALSE(s.entry(s.context, 0, &e));
  EXPECT_EQ(read_all(s, 1, 90), a);
  EXPECT_EQ(read_all(s, 2, 256), b);
  uint8_t byte;
  EXPECT_EQ(s.read(s.context, 1, 3000, &byte, 1), 0) << "past the end";
  EXPECT_EQ(s.append(s.context, a.data(), 10), 0) << "no log open";
}

TEST(RamLogStore, AFullRegionEndsTheOpenLogAndRefusesANewOne) {
  std::vector<uint8_t> region(1000);
  RamLogStore ram;
  ram.init(region.data(), static_cast<uint32_t>(region.size()));
  const LogStore& s = ram.store();
  const auto a = pattern(700, 3);
  ASSERT_TRUE(s.open(s.context, 0));
  EXPECT_EQ(s.append(s.context, a.data(), 700), 700);
  EXPECT_EQ(s.append(s.context, a.data(), 700), 300) << "the rest of the region";
  EXPECT_EQ(s.append(s.context, a.data(), 1), 0);
  EXPECT_FALSE(s.erase_all(s.context)) << "refused while a log is open";
  s.close(s.context);
  EXPECT_FALSE(s.open(s.context, 0)) << "no room for another log";
  EXPECT_EQ(s.count(s.context), 1);
  EXPECT_TRUE(s.erase_all(s.context));
  EXPECT_EQ(s.count(s.context), 0);
  EXPECT_TRUE(s.open(s.context, 0)) << "room again after the erase";
}

TEST(RamLogStore, HoldsAtMostItsIndexOfLogs) {
  std::vector<uint8_t> region(1000);
  RamLogStore ram;
  ram.init(region.data(), static_cast<uint32_t>(region.size()));
  const LogStore& s = ram.store();
  for (int i = 0; i < RamLogStore::kMaxLogs; ++i) {
    ASSERT_TRUE(s.open(s.context, 0)) << i;
    s.close(s.context);
  }
  EXPECT_FALSE(s.open(s.context, 0));
  EXPECT_EQ(s.count(s.context), RamLogStore::kMaxLogs);
}

}  // namespace
