// The scenario's log download client (quad/sim/log_download.h) against a scripted vehicle: the newest log
// is picked, its bytes arrive in LOG_DATA, a lost frame's range is asked for again, and a vehicle that
// stays silent ends the download as failed.
#include <gtest/gtest.h>

#include <vector>

#include "quad/sim/log_download.h"

namespace {

namespace mav = quad::mavlink;
using quad::sim::LogDownload;
using quad::sim::LogDownloadRequest;

// Encodes a message and hands its frame to `take` while the parser's buffer holds it (mav::Frame views it).
template <class Msg, class Take>
void as_frame(const Msg& m, Take take) {
  mav::Sender sender(1, 1);
  uint8_t buf[mav::max_frame_length<Msg>()];
  const size_t n = sender.encode(m, buf, sizeof buf);
  mav::Parser parser;
  parser.feed(buf, n, take);
}

struct Vehicle {
  std::vector<mav::LogRequestData> data_requests;
  int lists = 0, ends = 0;
  LogDownload client{LogDownload::Link{[this](const mav::LogRequestList&, double) { ++lists; },
                                       [this](const mav::LogRequestData& m, double) { data_requests.push_back(m); },
                                       [this](const mav::LogRequestEnd&, double) { ++ends; }}};
  void entry(uint16_t id, uint32_t size, uint16_t count, double t) {
    mav::LogEntry e;
    e.id = id;
    e.size = size;
    e.num_logs = count;
    e.last_log_num = count;
    as_frame(e, [&](const mav::Frame& f) { client.on_frame(f, t); });
  }
  void data(uint16_t id, uint32_t ofs, uint8_t count, double t) {
    mav::LogData d;
    d.id = id;
    d.ofs = ofs;
    d.count = count;
    for (uint8_t i = 0; i < count; ++i) d.data[i] = static_cast<uint8_t>((ofs + i) * 7u);
    as_frame(d, [&](const mav::Frame& f) { client.on_frame(f, t); });
  }
};

TEST(LogDownload, TakesTheNewestLogAndAsksAgainForALostRange) {
  Vehicle v;
  v.client.start(1.0, LogDownloadRequest{});
  EXPECT_EQ(v.lists, 1);
  v.entry(1, 5000, 2, 1.1);
  v.entry(2, 200, 2, 1.2);
  ASSERT_EQ(v.data_requests.size(), 1u);
  EXPECT_EQ(v.data_requests[0].id, 2);
  EXPECT_EQ(v.data_requests[0].ofs, 0u);
  EXPECT_EQ(v.data_requests[0].count, 200u);
  v.data(2, 0, 90, 1.3);
  v.data(2, 180, 20, 1.4);  // the frame at 90 was lost on the radio
  v.data(2, 200, 0, 1.5);   // the end of the stream: the gap is asked for at once
  ASSERT_EQ(v.data_requests.size(), 2u);
  EXPECT_EQ(v.data_requests[1].ofs, 90u);
  EXPECT_EQ(v.data_requests[1].count, 90u);
  EXPECT_FALSE(v.client.complete());
  v.data(2, 90, 90, 1.6);
  ASSERT_TRUE(v.client.complete());
  EXPECT_EQ(v.ends, 1);
  const std::vector<uint8_t> bytes = v.client.contiguous();
  ASSERT_EQ(bytes.size(), 200u);
  for (uint32_t i = 0; i < bytes.size(); ++i) ASSERT_EQ(bytes[i], static_cast<uint8_t>(i * 7u)) << i;
  EXPECT_NEAR(v.client.rate_bytes_s(), 200 / (1.6 - 1.2), 1e-6);
}

TEST(LogDownload, ANamedLogUpToALimitAndAQuietVehicleAskedAgainThenGivenUp) {
  Vehicle v;
  LogDownloadRequest r;
  r.id = 1;
  r.max_bytes = 100;
  v.client.start(0.0, r);
  v.entry(1, 5000, 2, 0.1);
  v.entry(2, 200, 2, 0.2);
  ASSERT_EQ(v.data_requests.size(), 1u);
  EXPECT_EQ(v.data_requests[0].id, 1);
  EXPECT_EQ(v.data_requests[0].count, 100u);
  v.data(1, 0, 90, 0.3);
  v.client.poll(0.5);
  EXPECT_EQ(v.data_requests.size(), 1u) << "not yet quiet";
  v.client.poll(1.4);
  ASSERT_EQ(v.data_requests.size(), 2u);
  EXPECT_EQ(v.data_requests[1].ofs, 90u);
  EXPECT_EQ(v.data_requests[1].count, 10u);
  for (int i = 0; i < 2 * LogDownload::kMaxIdleRequests && v.client.active(); ++i) v.client.poll(2.5 + i * 1.1);
  EXPECT_FALSE(v.client.active());
  EXPECT_FALSE(v.client.complete());
  EXPECT_NE(v.client.failure().find("brought no data"), std::string::npos) << v.client.failure();
  EXPECT_EQ(v.client.contiguous().size(), 90u);
}

TEST(LogDownload, AVehicleWithoutLogsFailsTheDownload) {
  Vehicle v;
  v.client.start(0.0, LogDownloadRequest{});
  v.entry(0, 0, 0, 0.1);
  EXPECT_FALSE(v.client.active());
  EXPECT_EQ(v.client.failure(), "the vehicle holds no log");
}

}  // namespace
