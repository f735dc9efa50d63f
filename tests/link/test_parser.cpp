// Streaming parser: acceptance, every rejection reason, resynchronisation, statistics.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "message_testing.h"
#include "quad/link/mavlink.h"

namespace mav = quad::mavlink;
using mav::testing::random_message;

namespace {

template <class Msg>
std::vector<uint8_t> frame_of(const Msg& msg, uint8_t system_id = 1, uint8_t component_id = 1, uint8_t sequence = 0) {
  mav::FrameHeader header;
  header.system_id = system_id;
  header.component_id = component_id;
  header.sequence = sequence;
  std::vector<uint8_t> out(mav::max_frame_length<Msg>());
  out.resize(mav::encode(msg, header, out.data(), out.size()));
  return out;
}

// A frame built by hand, for ids and lengths the encoder would never produce.
std::vector<uint8_t> raw_frame(uint32_t message_id, uint8_t crc_extra, const std::vector<uint8_t>& payload,
                               uint8_t incompat_flags = 0) {
  std::vector<uint8_t> frame = {mav::kStx, static_cast<uint8_t>(payload.size()), incompat_flags, 0, 0, 1, 1,
                                static_cast<uint8_t>(message_id), static_cast<uint8_t>(message_id >> 8),
                                static_cast<uint8_t>(message_id >> 16)};
  for (uint8_t b : payload) frame.push_back(b);  // (not insert(): GCC 12 warns falsely on empty ranges)
  uint16_t crc = mav::crc_accumulate(frame.data() + 1, frame.size() - 1, mav::kCrcInit);
  crc = mav::crc_accumulate(crc_extra, crc);
  frame.push_back(static_cast<uint8_t>(crc & 0xFF));
  frame.push_back(static_cast<uint8_t>(crc >> 8));
  if (incompat_flags & mav::kIncompatFlagSigned) frame.insert(frame.end(), mav::kSignatureLength, 0x11);
  return frame;
}

void append(std::vector<uint8_t>& stream, const std::vector<uint8_t>& bytes) {
  stream.insert(stream.end(), bytes.begin(), bytes.end());
}

struct Seen {
  uint32_t message_id;
  uint8_t sequence;
  std::vector<uint8_t> bytes;
};

std::vector<Seen> feed_all(mav::Parser& parser, const std::vector<uint8_t>& stream) {
  std::vector<Seen> seen;
  parser.feed(stream.data(), stream.size(), [&](const mav::Frame& f) {
    seen.push_back({f.message_id, f.sequence, std::vector<uint8_t>(f.bytes, f.bytes + f.size)});
  });
  return seen;
}

}  // namespace

TEST(Parser, FrameCompletesOnItsLastByteOnly) {
  const std::vector<uint8_t> frame = frame_of(mav::Timesync{}, 1, 1, 9);
  mav::Parser parser;
  for (size_t i = 0; i + 1 < frame.size(); ++i) EXPECT_FALSE(parser.push(frame[i])) << i;
  ASSERT_TRUE(parser.push(frame.back()));
  EXPECT_EQ(parser.frame().message_id, mav::Timesync::kId);
  EXPECT_EQ(parser.frame().size, frame.size());
  EXPECT_FALSE(parser.next());
  EXPECT_EQ(parser.stats().frames_accepted, 1u);
  EXPECT_EQ(parser.stats().bytes_discarded, 0u);
}

TEST(Parser, BadChecksumIsRejectedAndTheNextFrameFound) {
  std::vector<uint8_t> corrupted = frame_of(mav::Heartbeat{}, 1, 1, 0);
  corrupted[12] ^= 0x40;  // a payload bit
  std::vector<uint8_t> stream = corrupted;
  append(stream, frame_of(mav::Heartbeat{}, 1, 1, 1));
  mav::Parser parser;
  const std::vector<Seen> seen = feed_all(parser, stream);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].sequence, 1);
  EXPECT_EQ(parser.stats().bad_checksum, 1u);
  EXPECT_EQ(parser.stats().bytes_discarded, corrupted.size());
}

TEST(Parser, EveryCrcCoveredByteMatters) {
  // Flip each bit of a frame in turn (except the start byte): the parser must never accept the result.
  std::mt19937_64 rng(1);
  const std::vector<uint8_t> good = frame_of(random_message<mav::ManualControl>(rng));
  for (size_t i = 1; i < good.size(); ++i) {
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<uint8_t> bad = good;
      bad[i] ^= static_cast<uint8_t>(1 << bit);
      mav::Parser parser;
      EXPECT_TRUE(feed_all(parser, bad).empty()) << "byte " << i << " bit " << bit;
    }
  }
}

TEST(Parser, FramesInsideARejectedCandidateAreFound) {
  // A long frame cut short (a lost radio packet) claims the bytes of the two short frames after it.
  // When its CRC fails, the rescan from the byte after its start must find both, then the third.
  std::mt19937_64 rng(2);
  std::vector<uint8_t> cut = frame_of(random_message<mav::HilActuatorControls>(rng));
  ASSERT_GT(cut[1], 60);  // the full claimed length swallows both heartbeats
  cut.resize(20);
  std::vector<uint8_t> stream = cut;
  append(stream, frame_of(mav::Heartbeat{}, 1, 1, 1));
  append(stream, frame_of(mav::Heartbeat{}, 1, 1, 2));
  append(stream, frame_of(random_message<mav::HilSensor>(rng), 1, 1, 3));

  mav::Parser parser;
  const std::vector<Seen> seen = feed_all(parser, stream);
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen[0].sequence, 1);
  EXPECT_EQ(seen[1].sequence, 2);
  EXPECT_EQ(seen[2].sequence, 3);
  EXPECT_EQ(seen[2].message_id, mav::HilSensor::kId);
  EXPECT_EQ(parser.stats().bytes_discarded, cut.size());

  // The same with push()/next() by hand: one byte completes both heartbeats at once.
  mav::Parser by_hand;
  int completed = 0;
  int most_in_one_push = 0;
  for (uint8_t b : stream) {
    int this_push = 0;
    for (bool ready = by_hand.push(b); ready; ready = by_hand.next()) ++this_push;
    completed += this_push;
    most_in_one_push = std::max(most_in_one_push, this_push);
  }
  EXPECT_EQ(completed, 3);
  EXPECT_EQ(most_in_one_push, 2);
}

TEST(Parser, FalseStartBytesInGarbageAreSkipped) {
  const std::vector<uint8_t> garbage = {0x00, 0xFD, 0xFD, 0x05, 0xFD, 0x00, 0x00, 0x00, 0xFD};
  std::vector<uint8_t> stream = garbage;
  append(stream, frame_of(mav::CommandAck{}, 1, 1, 4));
  mav::Parser parser;
  const std::vector<Seen> seen = feed_all(parser, stream);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].message_id, mav::CommandAck::kId);
  EXPECT_EQ(parser.stats().bytes_discarded, garbage.size());
}

TEST(Parser, UnknownMessageIdsAreCountedAndDropped) {
  std::vector<uint8_t> stream = raw_frame(2, 137, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12});  // SYSTEM_TIME
  append(stream, raw_frame(0x012345, 0, {1}));
  append(stream, frame_of(mav::Heartbeat{}));
  mav::Parser parser;
  const std::vector<Seen> seen = feed_all(parser, stream);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].message_id, mav::Heartbeat::kId);
  EXPECT_EQ(parser.stats().unknown_message, 2u);
}

TEST(Parser, CustomLookupAcceptsMoreMessages) {
  const auto lookup = [](uint32_t id, mav::MessageInfo* info) {
    if (id == 2) {  // SYSTEM_TIME: CRC_EXTRA 137, 12 bytes
      *info = mav::MessageInfo{137, 12};
      return true;
    }
    return mav::find_message_info(id, info);
  };
  mav::Parser parser(lookup);
  std::vector<uint8_t> stream = raw_frame(2, 137, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12});
  append(stream, frame_of(mav::Heartbeat{}));
  const std::vector<Seen> seen = feed_all(parser, stream);
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(seen[0].message_id, 2u);
  EXPECT_EQ(parser.stats().unknown_message, 0u);
}

TEST(Parser, PayloadLongerThanTheDefinitionIsRejected) {
  std::vector<uint8_t> stream = raw_frame(mav::Heartbeat::kId, mav::Heartbeat::kCrcExtra, std::vector<uint8_t>(10, 7));
  append(stream, raw_frame(mav::Heartbeat::kId, mav::Heartbeat::kCrcExtra, std::vector<uint8_t>(9, 7)));
  mav::Parser parser;
  const std::vector<Seen> seen = feed_all(parser, stream);
  ASSERT_EQ(seen.size(), 1u);
  EXPECT_EQ(seen[0].bytes.size(), 10u + 9u + 2u);
  EXPECT_EQ(parser.stats().bad_length, 1u);
}

TEST(Parser, UnsupportedIncompatFlagsAreRejected) {
  std::vector<uint8_t> stream = raw_frame(mav::Heartbeat::kId, mav::Heartbeat::kCrcExtra, {1, 2, 3}, 0x02);
  append(stream, raw_frame(mav::Heartbeat::kId, mav::Heartbeat::kCrcExtra, {1, 2, 3}, 0x01));
  mav::Parser parser;
  const std::vector<Seen> seen = feed_all(parser, stream);
  ASSERT_EQ(seen.size(), 1u);  // the signed one
  EXPECT_EQ(seen[0].bytes.size(), 10u + 3u + 2u + 13u);
  EXPECT_EQ(parser.stats().unsupported_flags, 1u);
}

TEST(Parser, EmptyPayloadIsAcceptedAndDecodesAsZero) {
  // node-mavlink truncates an all-zero payload to nothing.
  const std::vector<uint8_t> stream = raw_frame(mav::SysStatus::kId, mav::SysStatus::kCrcExtra, {});
  mav::Parser parser;
  int decoded = 0;
  parser.feed(stream.data(), stream.size(), [&](const mav::Frame& f) {
    std::mt19937_64 rng(4);
    mav::SysStatus status = random_message<mav::SysStatus>(rng);
    ASSERT_TRUE(mav::decode(f, status));
    EXPECT_EQ(mav::testing::payload_of(status), std::vector<uint8_t>(mav::SysStatus::kLength, 0));
    ++decoded;
  });
  EXPECT_EQ(decoded, 1);
}

TEST(Parser, SequenceGapsAreCountedPerSender) {
  std::vector<uint8_t> stream;
  for (int seq : {250, 251, 253, 254, 255, 0, 1, 5}) append(stream, frame_of(mav::Heartbeat{}, 1, 200, static_cast<uint8_t>(seq)));
  for (int seq : {10, 11, 12}) append(stream, frame_of(mav::Heartbeat{}, 255, 190, static_cast<uint8_t>(seq)));
  mav::Parser parser;
  feed_all(parser, stream);
  const mav::SenderStats* sim = parser.find_sender(1, 200);
  const mav::SenderStats* gcs = parser.find_sender(255, 190);
  ASSERT_NE(sim, nullptr);
  ASSERT_NE(gcs, nullptr);
  EXPECT_EQ(sim->received, 8u);
  EXPECT_EQ(sim->lost, 1u + 3u);  // 252, then 2..4 (the wrap 255 -> 0 is no gap)
  EXPECT_EQ(gcs->received, 3u);
  EXPECT_EQ(gcs->lost, 0u);
  EXPECT_EQ(parser.stats().sequence_lost, 4u);
  EXPECT_EQ(parser.find_sender(1, 1), nullptr);
}

TEST(Parser, SendersBeyondTheTableAreAcceptedButUntracked) {
  std::vector<uint8_t> stream;
  for (uint8_t sys = 1; sys <= mav::Parser::kMaxSenders + 2; ++sys) append(stream, frame_of(mav::Heartbeat{}, sys, 1, 0));
  mav::Parser parser;
  EXPECT_EQ(feed_all(parser, stream).size(), mav::Parser::kMaxSenders + 2u);
  EXPECT_EQ(parser.sender_count(), mav::Parser::kMaxSenders);
  EXPECT_EQ(parser.stats().untracked_sender_frames, 2u);
}

TEST(Parser, EveryByteIsAccountedFor) {
  std::mt19937_64 rng(8);
  std::vector<uint8_t> stream;
  for (int i = 0; i < 300; ++i) {
    for (int g = static_cast<int>(rng() % 20); g > 0; --g) stream.push_back(rng() % 4 == 0 ? 0xFD : static_cast<uint8_t>(rng()));
    append(stream, frame_of(random_message<mav::LocalPositionNed>(rng), 1, 1, static_cast<uint8_t>(i)));
  }
  stream.insert(stream.end(), {0xFD, 0x05, 0x00});  // a partial header at the end
  mav::Parser parser;
  size_t accepted_bytes = 0;
  parser.feed(stream.data(), stream.size(), [&](const mav::Frame& f) { accepted_bytes += f.size; });
  EXPECT_GE(parser.stats().frames_accepted, 300u);
  EXPECT_EQ(accepted_bytes + parser.stats().bytes_discarded + parser.held_bytes(), stream.size());
  EXPECT_EQ(parser.held_bytes(), 3u);
  parser.reset();
  EXPECT_EQ(parser.held_bytes(), 0u);
  EXPECT_EQ(accepted_bytes + parser.stats().bytes_discarded, stream.size());
}
