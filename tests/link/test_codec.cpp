// Link codec: CRC, message definitions, frame encoding (truncation, capacity, signing) and decoding.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "message_testing.h"
#include "quad/link/mavlink.h"

namespace mav = quad::mavlink;
using mav::testing::payload_of;
using mav::testing::random_message;

namespace {

std::vector<uint8_t> from_hex(const std::string& hex) {
  std::vector<uint8_t> bytes;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) bytes.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return bytes;
}

template <class Msg>
std::vector<uint8_t> encode_frame(const Msg& msg, mav::FrameHeader header = {}) {
  std::vector<uint8_t> out(mav::max_frame_length<Msg>(true));
  const size_t size = mav::encode(msg, header, out.data(), out.size());
  out.resize(size);
  return out;
}

// Runs bytes through a parser; returns the frames' payloads decoded as Msg (one per frame of that id).
template <class Msg>
std::vector<Msg> parse_all(const std::vector<uint8_t>& bytes, std::vector<mav::Frame>* frames = nullptr) {
  mav::Parser parser;
  std::vector<Msg> messages;
  parser.feed(bytes.data(), bytes.size(), [&](const mav::Frame& frame) {
    if (frames) frames->push_back(frame);
    Msg msg;
    if (mav::decode(frame, msg)) messages.push_back(msg);
  });
  return messages;
}

}  // namespace

TEST(Crc, McrF4xxCheckValue) {
  // The catalogue check value of CRC-16/MCRF4XX: CRC of the ASCII digits "123456789".
  const char* digits = "123456789";
  EXPECT_EQ(mav::crc_accumulate(reinterpret_cast<const uint8_t*>(digits), 9, mav::kCrcInit), 0x6F91);
}

TEST(Messages, IdsCrcExtraAndLengthsMatchMavlinkMappings) {
  // Values read from mavlink-mappings (node-mavlink's definitions): id, CRC_EXTRA, base length, length.
  struct Expected {
    uint32_t id;
    uint8_t crc_extra;
    uint8_t base_length;
    uint8_t length;
  };
  const Expected expected[] = {
      {0, 50, 9, 9},      {1, 124, 31, 43},   {20, 214, 20, 20},  {21, 159, 2, 2},    {22, 220, 25, 25},
      {23, 168, 23, 23},  {31, 246, 32, 48},  {32, 185, 28, 28},  {69, 243, 11, 30},  {76, 152, 33, 33},
      {77, 143, 3, 10},   {84, 143, 53, 53},  {93, 47, 81, 81},   {102, 158, 32, 117}, {107, 108, 64, 65},
      {111, 34, 16, 18},  {115, 4, 64, 64},   {117, 128, 6, 6},   {118, 56, 14, 14},  {119, 116, 12, 12},
      {120, 134, 97, 97}, {121, 237, 2, 2},   {122, 203, 2, 2},   {138, 109, 36, 120}, {149, 200, 30, 60},
      {230, 163, 42, 42},
      {245, 130, 2, 2},
      {253, 83, 51, 54},
  };
  size_t index = 0;
  mav::for_each_message_type([&](auto msg) {
    using Msg = decltype(msg);
    ASSERT_LT(index, sizeof expected / sizeof expected[0]);
    const Expected& e = expected[index++];
    EXPECT_EQ(Msg::kId, e.id) << Msg::kName;
    EXPECT_EQ(Msg::kCrcExtra, e.crc_extra) << Msg::kName;
    EXPECT_EQ(Msg::kBaseLength, e.base_length) << Msg::kName;
    EXPECT_EQ(Msg::kLength, e.length) << Msg::kName;
    mav::MessageInfo info{0, 0};
    ASSERT_TRUE(mav::find_message_info(Msg::kId, &info)) << Msg::kName;
    EXPECT_EQ(info.crc_extra, e.crc_extra) << Msg::kName;
    EXPECT_EQ(info.max_length, e.length) << Msg::kName;
  });
  EXPECT_EQ(index, sizeof expected / sizeof expected[0]);
  mav::MessageInfo info{0, 0};
  EXPECT_FALSE(mav::find_message_info(2, &info));         // SYSTEM_TIME: not part of this system
  EXPECT_FALSE(mav::find_message_info(0xFFFFFF, &info));
}

TEST(Encode, HeartbeatMatchesNodeMavlinkBytes) {
  // Reference frame serialised by node-mavlink 2.3 (sysid 1, compid 1, seq 7).
  mav::Heartbeat hb;
  hb.type = mav::kMavTypeQuadrotor;
  hb.autopilot = mav::kMavAutopilotGeneric;
  hb.base_mode = mav::kModeFlagSafetyArmed | mav::kModeFlagCustomModeEnabled;
  hb.custom_mode = 0x01020304;
  hb.system_status = mav::kStateActive;
  mav::FrameHeader header;
  header.system_id = 1;
  header.component_id = 1;
  header.sequence = 7;
  EXPECT_EQ(encode_frame(hb, header), from_hex("fd09000007010100000004030201020081040331bb"));
}

TEST(Encode, TruncatedHilSensorMatchesNodeMavlinkBytes) {
  // node-mavlink reference (sysid 1, compid 200, seq 255): the zero tail (fields_updated's upper bytes,
  // the id extension) is dropped, 61 of 65 payload bytes remain.
  mav::HilSensor sensor;
  sensor.time_usec = 1234567;
  sensor.zacc = -9.80665f;
  sensor.fields_updated = 0x3F;
  mav::FrameHeader header;
  header.system_id = 1;
  header.component_id = 200;
  header.sequence = 255;
  const std::vector<uint8_t> frame = encode_frame(sensor, header);
  EXPECT_EQ(frame, from_hex("fd3d0000ff01c86b000087d612000000000000000000000000000ae81cc100000000000000000000000000000000"
                            "0000000000000000000000000000000000000000000000003fe9ac"));
  EXPECT_EQ(frame[1], 61);
}

TEST(Encode, EveryMessageRoundTripsThroughTheParser) {
  std::mt19937_64 rng(42);
  mav::for_each_message_type([&](auto prototype) {
    using Msg = decltype(prototype);
    for (int i = 0; i < 200; ++i) {
      const Msg sent = random_message<Msg>(rng);
      mav::FrameHeader header;
      header.system_id = static_cast<uint8_t>(rng());
      header.component_id = static_cast<uint8_t>(rng());
      header.sequence = static_cast<uint8_t>(i);
      std::vector<mav::Frame> frames;
      const std::vector<Msg> received = parse_all<Msg>(encode_frame(sent, header), &frames);
      ASSERT_EQ(received.size(), 1u) << Msg::kName;
      EXPECT_EQ(payload_of(received[0]), payload_of(sent)) << Msg::kName;
      EXPECT_EQ(frames[0].system_id, header.system_id);
      EXPECT_EQ(frames[0].component_id, header.component_id);
      EXPECT_EQ(frames[0].sequence, header.sequence);
      EXPECT_EQ(frames[0].message_id, Msg::kId);
      EXPECT_FALSE(frames[0].is_signed());
    }
  });
}

TEST(Encode, AllZeroPayloadKeepsItsFirstByte) {
  mav::ParamRequestList zero;
  const std::vector<uint8_t> frame = encode_frame(zero);
  EXPECT_EQ(frame[1], 1);
  EXPECT_EQ(frame.size(), mav::kHeaderLength + 1 + mav::kChecksumLength);
  mav::HilSensor zero_sensor;
  EXPECT_EQ(encode_frame(zero_sensor)[1], 1);
}

TEST(Decode, TruncatedPayloadAndMissingExtensionsReadAsZero) {
  std::mt19937_64 rng(7);
  // Base fields set, extension zero: the frame is exactly as long as a pre-extension sender's.
  mav::HilSensor sent = random_message<mav::HilSensor>(rng);
  sent.fields_updated = 0x01FF0000;  // non-zero last base byte
  sent.id = 0;
  const std::vector<uint8_t> frame = encode_frame(sent);
  ASSERT_EQ(frame[1], mav::HilSensor::kBaseLength);

  std::vector<mav::Frame> frames;
  mav::Parser parser;
  mav::HilSensor received = random_message<mav::HilSensor>(rng);  // garbage in every field
  received.id = 99;
  parser.feed(frame.data(), frame.size(), [&](const mav::Frame& f) { ASSERT_TRUE(mav::decode(f, received)); });
  EXPECT_EQ(received.id, 0);
  EXPECT_EQ(payload_of(received), payload_of(sent));

  // Mostly zero message: everything after the truncation point must come back as zero, not as the
  // previous contents of the destination.
  mav::LandingTarget sparse;
  sparse.time_usec = 5;
  mav::LandingTarget decoded = random_message<mav::LandingTarget>(rng);
  const std::vector<uint8_t> sparse_frame = encode_frame(sparse);
  EXPECT_EQ(sparse_frame[1], 1);
  parser.feed(sparse_frame.data(), sparse_frame.size(), [&](const mav::Frame& f) { ASSERT_TRUE(mav::decode(f, decoded)); });
  EXPECT_EQ(payload_of(decoded), payload_of(sparse));
}

TEST(Decode, RejectsOtherMessagesAndOverlongPayloads) {
  std::mt19937_64 rng(3);
  const mav::Heartbeat hb = random_message<mav::Heartbeat>(rng);
  const std::vector<uint8_t> frame = encode_frame(hb);
  mav::Parser parser;
  ASSERT_TRUE([&] {
    for (uint8_t b : frame)
      if (parser.push(b)) return true;
    return false;
  }());
  mav::HilSensor sensor;
  sensor.time_usec = 77;
  EXPECT_FALSE(mav::decode(parser.frame(), sensor));
  EXPECT_EQ(sensor.time_usec, 77u);

  // A frame view claiming more payload than the definition holds (the parser never delivers one, but
  // decode() must not read past the definition either).
  uint8_t payload[mav::kMaxPayloadLength] = {};
  mav::Frame overlong;
  overlong.message_id = mav::Heartbeat::kId;
  overlong.payload = payload;
  overlong.payload_length = mav::Heartbeat::kLength + 1;
  mav::Heartbeat untouched;
  untouched.custom_mode = 12;
  EXPECT_FALSE(mav::decode(overlong, untouched));
  EXPECT_EQ(untouched.custom_mode, 12u);
}

TEST(Encode, RefusesBuffersThatCannotHoldTheFullFrame) {
  std::mt19937_64 rng(5);
  const mav::VisionPositionEstimate msg = random_message<mav::VisionPositionEstimate>(rng);
  std::vector<uint8_t> buffer(mav::max_frame_length<mav::VisionPositionEstimate>(), 0xAA);
  EXPECT_EQ(buffer.size(), 10u + 117u + 2u);
  EXPECT_EQ(mav::encode(msg, mav::FrameHeader{}, buffer.data(), buffer.size() - 1), 0u);
  EXPECT_EQ(buffer, std::vector<uint8_t>(buffer.size(), 0xAA));  // nothing written
  EXPECT_EQ(mav::encode(msg, mav::FrameHeader{}, nullptr, 1000), 0u);
  EXPECT_GT(mav::encode(msg, mav::FrameHeader{}, buffer.data(), buffer.size()), 0u);

  mav::FrameHeader signed_header;
  signed_header.incompat_flags = mav::kIncompatFlagSigned;  // needs 13 more bytes
  EXPECT_EQ(mav::encode(msg, signed_header, buffer.data(), buffer.size()), 0u);
}

TEST(Encode, RefusesIncompatFlagsItDoesNotImplement) {
  uint8_t buffer[64];
  mav::FrameHeader header;
  header.incompat_flags = 0x02;
  EXPECT_EQ(mav::encode(mav::Heartbeat{}, header, buffer, sizeof buffer), 0u);
}

TEST(Encode, SignedFrameReservesTheSignatureBlockAndParsesAsSigned) {
  std::mt19937_64 rng(11);
  const mav::CommandLong cmd = random_message<mav::CommandLong>(rng);
  mav::FrameHeader header;
  header.system_id = 255;
  header.component_id = 190;
  const std::vector<uint8_t> unsigned_frame = encode_frame(cmd, header);
  header.incompat_flags = mav::kIncompatFlagSigned;
  const std::vector<uint8_t> signed_frame = encode_frame(cmd, header);
  ASSERT_EQ(signed_frame.size(), unsigned_frame.size() + mav::kSignatureLength);
  EXPECT_EQ(signed_frame[2], mav::kIncompatFlagSigned);
  for (size_t i = unsigned_frame.size(); i < signed_frame.size(); ++i) EXPECT_EQ(signed_frame[i], 0);

  std::vector<mav::Frame> frames;
  mav::Parser parser;
  std::vector<uint8_t> seen;
  parser.feed(signed_frame.data(), signed_frame.size(), [&](const mav::Frame& f) {
    frames.push_back(f);
    ASSERT_TRUE(f.is_signed());
    EXPECT_EQ(f.signature, f.bytes + f.size - mav::kSignatureLength);
    seen.assign(f.bytes, f.bytes + f.size);
    mav::CommandLong decoded;
    ASSERT_TRUE(mav::decode(f, decoded));
    EXPECT_EQ(payload_of(decoded), payload_of(cmd));
  });
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(seen, signed_frame);
}

TEST(Sender, SequenceAdvancesPerWrittenFrameAndWraps) {
  mav::Sender sender(1, mav::kCompIdAutopilot1);
  uint8_t buffer[mav::max_frame_length<mav::Heartbeat>()];
  for (int i = 0; i < 300; ++i) {
    ASSERT_GT(sender.encode(mav::Heartbeat{}, buffer, sizeof buffer), 0u);
    EXPECT_EQ(buffer[4], static_cast<uint8_t>(i));
    EXPECT_EQ(buffer[5], 1);
    EXPECT_EQ(buffer[6], mav::kCompIdAutopilot1);
  }
  const uint8_t before = sender.next_sequence();
  EXPECT_EQ(sender.encode(mav::Heartbeat{}, buffer, 5), 0u);
  EXPECT_EQ(sender.next_sequence(), before);
}

TEST(Text, CopyPadsTruncatesAndComparesWithoutATerminator) {
  mav::ParamSet set;
  std::memset(set.param_id, 'x', sizeof set.param_id);
  EXPECT_TRUE(mav::copy_text(set.param_id, "ATT_KP"));
  EXPECT_EQ(std::string(set.param_id, 6), "ATT_KP");
  for (size_t i = 6; i < sizeof set.param_id; ++i) EXPECT_EQ(set.param_id[i], '\0') << i;
  EXPECT_EQ(mav::text_length(set.param_id), 6u);
  EXPECT_TRUE(mav::text_equals(set.param_id, "ATT_KP"));
  EXPECT_FALSE(mav::text_equals(set.param_id, "ATT_K"));
  EXPECT_FALSE(mav::text_equals(set.param_id, "ATT_KPX"));

  // A 16-character name fills the field with no terminator; 17 characters do not fit.
  EXPECT_TRUE(mav::copy_text(set.param_id, "ABCDEFGHIJKLMNOP"));
  EXPECT_EQ(mav::text_length(set.param_id), 16u);
  EXPECT_TRUE(mav::text_equals(set.param_id, "ABCDEFGHIJKLMNOP"));
  EXPECT_FALSE(mav::text_equals(set.param_id, "ABCDEFGHIJKLMNOPQ"));
  EXPECT_FALSE(mav::copy_text(set.param_id, "ABCDEFGHIJKLMNOPQ"));
  EXPECT_EQ(std::string(set.param_id, 16), "ABCDEFGHIJKLMNOP");
}
