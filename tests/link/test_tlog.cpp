// The link record writer (quad/link/tlog.h): the byte layout of a record, frames reassembled from reads
// of any size, damaged and unknown frames left out, time that never goes back, errors naming the file.
// node-mavlink's reading of whole records is tested on the tools' records (tests/sim, tests/firmware).
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>

#include "quad/link/mavlink.h"
#include "quad/link/tlog.h"

namespace mav = quad::mavlink;

namespace {

std::vector<uint8_t> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::vector<uint8_t> heartbeat_frame(mav::Sender& sender) {
  mav::Heartbeat hb;
  hb.custom_mode = 2;
  std::vector<uint8_t> out(mav::max_frame_length<mav::Heartbeat>());
  out.resize(sender.encode(hb, out.data(), out.size()));
  return out;
}

std::vector<uint8_t> statustext_frame(mav::Sender& sender, const char* text) {
  mav::Statustext st;
  mav::copy_text(st.text, text);
  std::vector<uint8_t> out(mav::max_frame_length<mav::Statustext>());
  out.resize(sender.encode(st, out.data(), out.size()));
  return out;
}

uint64_t big_endian_at(const std::vector<uint8_t>& b, size_t at) {
  uint64_t v = 0;
  for (size_t i = 0; i < 8; ++i) v = (v << 8) | b[at + i];
  return v;
}

std::string temp_path(const char* name) { return ::testing::TempDir() + name; }

}  // namespace

TEST(Tlog, RecordIsBigEndianMicrosecondsThenTheFrame) {
  const std::string path = temp_path("tlog_layout.tlog");
  mav::Sender sender(1, 1);
  const std::vector<uint8_t> frame = heartbeat_frame(sender);
  {
    quad::tlog::TlogWriter w(path);
    w.write(0x0102030405060708ull, frame.data(), frame.size());
    EXPECT_EQ(w.records(), 1u);
  }
  const std::vector<uint8_t> b = read_bytes(path);
  ASSERT_EQ(b.size(), 8 + frame.size());
  EXPECT_EQ(std::vector<uint8_t>(b.begin(), b.begin() + 8), (std::vector<uint8_t>{1, 2, 3, 4, 5, 6, 7, 8}));
  EXPECT_EQ(std::vector<uint8_t>(b.begin() + 8, b.end()), frame);
}

TEST(Tlog, FramesSplitAcrossReadsBecomeOneRecordEach) {
  // Three frames fed in pieces of every size from 1 to 40 bytes, noise between them: always three
  // records, each a whole frame stamped with the time of the read that completed it.
  mav::Sender sender(1, 1);
  std::vector<uint8_t> stream, expected;
  const std::vector<std::vector<uint8_t>> frames = {heartbeat_frame(sender), statustext_frame(sender, "split"),
                                                     heartbeat_frame(sender)};
  for (const auto& f : frames) {
    stream.insert(stream.end(), {0x00, 0x55});  // noise: no start byte
    stream.insert(stream.end(), f.begin(), f.end());
  }
  for (size_t piece = 1; piece <= 40; ++piece) {
    const std::string path = temp_path("tlog_split.tlog");
    uint64_t t = 1700000000000000ull;
    std::vector<uint64_t> completion;  // the time of the read that holds each frame's last byte
    {
      quad::tlog::TlogWriter w(path);
      quad::tlog::TlogStream s(w);
      size_t frame_end = 0, frame_index = 0;
      for (size_t at = 0; at < stream.size(); at += piece, t += 1000) {
        const size_t n = std::min(piece, stream.size() - at);
        s.feed(stream.data() + at, n, t);
        while (frame_index < frames.size()) {
          const size_t end = frame_end + 2 + frames[frame_index].size();
          if (end > at + n) break;
          completion.push_back(t);
          frame_end = end;
          ++frame_index;
        }
      }
      EXPECT_EQ(w.records(), 3u) << "piece " << piece;
    }
    const std::vector<uint8_t> b = read_bytes(path);
    size_t at = 0;
    for (size_t i = 0; i < frames.size(); ++i) {
      ASSERT_LE(at + 8 + frames[i].size(), b.size()) << "piece " << piece;
      EXPECT_EQ(big_endian_at(b, at), completion[i]) << "piece " << piece << " frame " << i;
      EXPECT_EQ(std::vector<uint8_t>(b.begin() + static_cast<long>(at + 8), b.begin() + static_cast<long>(at + 8 + frames[i].size())),
                frames[i])
          << "piece " << piece << " frame " << i;
      at += 8 + frames[i].size();
    }
    EXPECT_EQ(at, b.size());
  }
}

TEST(Tlog, DamagedAndUnknownFramesAreNotRecorded) {
  const std::string path = temp_path("tlog_damaged.tlog");
  mav::Sender sender(1, 1);
  std::vector<uint8_t> damaged = heartbeat_frame(sender);
  damaged[12] ^= 0x01;  // a payload bit: the CRC no longer matches
  std::vector<uint8_t> unknown = heartbeat_frame(sender);
  unknown[7] = 0x7F;  // message id 127 + CRC unchanged: unknown to the codec
  const std::vector<uint8_t> good = heartbeat_frame(sender);
  quad::tlog::TlogWriter w(path);
  quad::tlog::TlogStream s(w);
  s.feed(damaged.data(), damaged.size(), 1);
  s.feed(unknown.data(), unknown.size(), 2);
  s.feed(good.data(), good.size(), 3);
  EXPECT_EQ(w.records(), 1u);
  EXPECT_EQ(s.stats().bad_checksum, 1u);
  EXPECT_EQ(s.stats().unknown_message, 1u);
}

TEST(Tlog, TheDialectsMessagesAreRecorded) {
  const std::string path = temp_path("tlog_dialect.tlog");
  mav::Sender sender(255, 190);
  mav::SetupSigning setup;
  std::vector<uint8_t> frame(mav::max_frame_length<mav::SetupSigning>());
  frame.resize(sender.encode(setup, frame.data(), frame.size()));
  quad::tlog::TlogWriter w(path);
  quad::tlog::TlogStream s(w);
  s.feed(frame.data(), frame.size(), 1);
  EXPECT_EQ(w.records(), 1u);
}

TEST(Tlog, TimeNeverGoesBack) {
  const std::string path = temp_path("tlog_time.tlog");
  mav::Sender sender(1, 1);
  const std::vector<uint8_t> f = heartbeat_frame(sender);
  {
    quad::tlog::TlogWriter w(path);
    w.write(2000, f.data(), f.size());
    w.write(1500, f.data(), f.size());  // handled a step late: takes the previous record's time
    w.write(2500, f.data(), f.size());
  }
  const std::vector<uint8_t> b = read_bytes(path);
  const size_t r = 8 + f.size();
  ASSERT_EQ(b.size(), 3 * r);
  EXPECT_EQ(big_endian_at(b, 0), 2000u);
  EXPECT_EQ(big_endian_at(b, r), 2000u);
  EXPECT_EQ(big_endian_at(b, 2 * r), 2500u);
}

TEST(Tlog, AFileThatCannotBeCreatedIsNamed) {
  try {
    quad::tlog::TlogWriter w("/nonexistent/dir/link.tlog");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/link.tlog: cannot create"), std::string::npos) << e.what();
  }
}

TEST(Tlog, WallClockIsMicrosecondsSinceTheEpoch) {
  const uint64_t now = quad::tlog::unix_micros_now();
  EXPECT_GT(now, 1577836800000000ull);  // 2020-01-01
  EXPECT_LT(now, 4102444800000000ull);  // 2100-01-01
}
