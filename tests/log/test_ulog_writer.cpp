// The ULog writer: its bytes as the ULog specification lays them out, read back by the field's reader
// (@foxglove/ulog through tools/node/ulog_check.js), and whole records only when the store is busy.
#include <gtest/gtest.h>

#include <cstring>
#include <string>
#include <vector>

#include "log_test_support.h"
#include "quad/firmware/ulog_writer.h"

namespace {

using quad::fw::UlogFields;
using quad::fw::UlogWriter;
using quad::fw::test::RamLogStore;
using quad::fw::test::read_with_node;
using quad::fw::test::topic_number;

// A topic of its own: a counter, so a reader can tell which records arrived.
const quad::fw::FlashText kCounter = QUAD_TEXT("counter:uint64_t timestamp;uint32_t n;float[2] v;");
constexpr uint8_t kCounterBytes = 8 + 4 + 8;

void definitions(UlogWriter& w) {
  ASSERT_TRUE(w.format(kCounter));
  ASSERT_TRUE(w.info(QUAD_TEXT("sys_name"), QUAD_TEXT("quad-stereo")));
  ASSERT_TRUE(w.info(QUAD_TEXT("loop_hz"), 400u));
  ASSERT_TRUE(w.parameter("SYS_LOOP_HZ", 400.0f));
  ASSERT_TRUE(w.add_logged(0, kCounter));
}

bool counter(UlogWriter& w, uint32_t n) {
  uint8_t* p = w.begin_data(0, kCounterBytes);
  if (p == nullptr) return false;
  const float v[2] = {0.5f * static_cast<float>(n), -1.0f};
  UlogFields(p).u64(1000u * n).u32(n).f32(v, 2);
  w.commit();
  return true;
}

TEST(UlogWriter, FileHeaderAndFlagBitsAsTheSpecificationLaysThemOut) {
  RamLogStore ram;
  UlogWriter w;
  w.attach(ram.store());
  ASSERT_TRUE(w.open(0x0102030405060708ull, 0));
  ASSERT_EQ(ram.logs.size(), 1u);
  const std::vector<uint8_t>& b = ram.logs[0];
  ASSERT_EQ(b.size(), 16u + 3u + 40u);
  // "ULog" 0x01 0x12 0x35, version 1, uint64 timestamp (little-endian).
  const uint8_t header[16] = {'U', 'L', 'o', 'g', 0x01, 0x12, 0x35, 0x01, 8, 7, 6, 5, 4, 3, 2, 1};
  EXPECT_EQ(std::memcmp(b.data(), header, 16), 0);
  // 'B': msg_size 40, compat and incompat flags all zero, three zero appended offsets.
  EXPECT_EQ(b[16], 40);
  EXPECT_EQ(b[17], 0);
  EXPECT_EQ(b[18], 'B');
  for (size_t i = 19; i < b.size(); ++i) EXPECT_EQ(b[i], 0) << i;
}

TEST(UlogWriter, TheFieldsReaderReadsEveryKindOfRecord) {
  RamLogStore ram;
  UlogWriter w;
  w.attach(ram.store());
  ASSERT_TRUE(w.open(5, 0));
  definitions(w);
  for (uint32_t n = 0; n < 50; ++n) ASSERT_TRUE(counter(w, n));
  const char text[] = "LANDING: land commanded";
  ASSERT_TRUE(w.logged_string('6', 49000, text, sizeof text - 1));
  ASSERT_TRUE(w.parameter("SYS_LOOP_HZ", 200.0f));
  w.close();
  EXPECT_EQ(w.dropped(), 0u);
  const auto r = read_with_node(ram.logs[0], "every_kind");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(topic_number(r.out, "counter", "count"), 50);
  EXPECT_EQ(topic_number(r.out, "counter", "first_timestamp"), 0);
  EXPECT_EQ(topic_number(r.out, "counter", "last_timestamp"), 49000);
  EXPECT_NE(r.out.find("\"monotonic\": true"), std::string::npos);
  EXPECT_NE(r.out.find("\"n\": 49"), std::string::npos);
  EXPECT_NE(r.out.find("\"sys_name\": \"quad-stereo\""), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"loop_hz\": 400"), std::string::npos);
  EXPECT_NE(r.out.find("\"SYS_LOOP_HZ\": 400"), std::string::npos);
  EXPECT_NE(r.out.find("\"key\": \"float SYS_LOOP_HZ\""), std::string::npos) << "the change in the data";
  EXPECT_NE(r.out.find("\"text\": \"LANDING: land commanded\""), std::string::npos);
  EXPECT_NE(r.out.find("\"level\": 54"), std::string::npos);
}

// A store that is busy at times and takes a few bytes at a time: every record reaches the file whole or
// not at all, the reader reads every byte, and the records it reads are those the writer did not drop.
void busy_store_run(uint16_t max_take, unsigned busy_every, unsigned busy_run, const char* name) {
  RamLogStore ram;
  ram.max_take = max_take;
  ram.busy_every = busy_every;
  ram.busy_run = busy_run;
  UlogWriter w;
  w.attach(ram.store());
  ASSERT_TRUE(w.open(0, 0));
  // The definitions wait for the store (never dropped).
  for (int i = 0; i < 5; ++i) {
    while (!w.flush()) {
    }
    switch (i) {
      case 0: ASSERT_TRUE(w.format(kCounter)); break;
      case 1: ASSERT_TRUE(w.info(QUAD_TEXT("sys_name"), QUAD_TEXT("quad-stereo"))); break;
      case 2: ASSERT_TRUE(w.parameter("SYS_LOOP_HZ", 400.0f)); break;
      case 3: ASSERT_TRUE(w.add_logged(0, kCounter)); break;
      default: break;
    }
  }
  constexpr uint32_t kRecords = 2000;
  uint32_t queued = 0;
  for (uint32_t n = 0; n < kRecords; ++n) queued += counter(w, n) ? 1u : 0u;
  while (!w.flush()) {
  }
  w.close();
  EXPECT_EQ(queued + w.dropped(), kRecords);
  EXPECT_GT(w.dropped(), 0u) << "the pattern must make the writer drop some records";
  EXPECT_GT(queued, kRecords / 4);
  const auto r = read_with_node(ram.logs[0], name);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(topic_number(r.out, "counter", "count"), static_cast<long>(queued));
  EXPECT_EQ(r.out.find("\"monotonic\": false"), std::string::npos);
}

// Busy for 24 calls in 40: the records of 24 calls (600 bytes) overflow the staging buffer.
static_assert(24 * (quad::fw::ulog::kDataHeaderBytes + kCounterBytes) > UlogWriter::kStagingBytes, "the busy run must overflow");
TEST(UlogWriter, BusyStoreGetsWholeRecordsOrNone) { busy_store_run(0xFFFF, 40, 24, "busy"); }
TEST(UlogWriter, StoreTakingAFewBytesAtATimeGetsWholeRecordsOrNone) { busy_store_run(7, 0, 0, "trickle"); }

TEST(UlogWriter, WithoutAStoreNothingOpens) {
  UlogWriter w;
  EXPECT_FALSE(w.open(0, 0));
  quad::fw::LogStore none{};
  w.attach(&none);
  EXPECT_FALSE(w.open(0, 0));
  EXPECT_FALSE(counter(w, 1));
  EXPECT_FALSE(w.is_open());
}

}  // namespace
