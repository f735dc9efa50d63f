// MAVLink v2 message signing: a node-mavlink golden frame, sign/verify round trips through the parser,
// every single-bit change rejected, replay and timestamp-window rules, unsigned frames, wrong and changed
// keys, the stream table and the clock.
#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "message_testing.h"
#include "quad/link/mavlink.h"

namespace mav = quad::mavlink;

namespace {

mav::SigningKey key_of(uint8_t first) {
  mav::SigningKey key;
  for (size_t i = 0; i < mav::kSigningKeyLength; ++i) key.bytes[i] = static_cast<uint8_t>(first + i);
  return key;
}

// A Frame over raw bytes laid out as the parser would describe them, for frames the parser would not
// deliver (a damaged CRC) or to hand the verifier a frame directly.
mav::Frame view(const std::vector<uint8_t>& bytes) {
  mav::Frame frame;
  frame.payload_length = bytes[1];
  frame.incompat_flags = bytes[2];
  frame.compat_flags = bytes[3];
  frame.sequence = bytes[4];
  frame.system_id = bytes[5];
  frame.component_id = bytes[6];
  frame.message_id = bytes[7] | (bytes[8] << 8) | (bytes[9] << 16);
  frame.payload = bytes.data() + mav::kHeaderLength;
  frame.bytes = bytes.data();
  frame.size = static_cast<uint16_t>(bytes.size());
  if ((bytes[2] & mav::kIncompatFlagSigned) != 0) frame.signature = bytes.data() + bytes.size() - mav::kSignatureLength;
  return frame;
}

// Recomputes the CRC after a change to header or payload, as an attacker without the key would.
void fix_crc(std::vector<uint8_t>& bytes, uint8_t crc_extra) {
  const size_t end = mav::kHeaderLength + bytes[1];
  uint16_t crc = mav::crc_accumulate(bytes.data() + 1, end - 1, mav::kCrcInit);
  crc = mav::crc_accumulate(crc_extra, crc);
  bytes[end] = static_cast<uint8_t>(crc & 0xFF);
  bytes[end + 1] = static_cast<uint8_t>(crc >> 8);
}

mav::HilSensor sensor_sample(uint64_t t) {
  mav::HilSensor s;
  s.time_usec = t;
  s.xacc = 0.12f;
  s.zacc = -9.81f;
  s.xgyro = 0.001f;
  s.fields_updated = 0x1FF;
  return s;
}

template <class Msg>
std::vector<uint8_t> signed_frame(mav::Sender& sender, mav::Signer& signer, const Msg& msg) {
  std::vector<uint8_t> out(mav::max_frame_length<Msg>(true));
  const size_t size = mav::encode_signed(sender, signer, msg, out.data(), out.size());
  EXPECT_GT(size, 0u);
  out.resize(size);
  return out;
}

// Everything the parser delivers from `bytes`, checked by `verifier`.
std::vector<mav::SignatureCheck> parse_and_check(const std::vector<uint8_t>& bytes, mav::SignatureVerifier& verifier) {
  mav::Parser parser;
  std::vector<mav::SignatureCheck> outcomes;
  parser.feed(bytes.data(), bytes.size(), [&](const mav::Frame& f) { outcomes.push_back(verifier.check(f)); });
  return outcomes;
}

uint64_t timestamp_of(const std::vector<uint8_t>& frame) {
  uint64_t t = 0;
  for (size_t i = 0; i < 6; ++i) t |= static_cast<uint64_t>(frame[frame.size() - 12 + i]) << (8 * i);
  return t;
}

class Signing : public ::testing::Test {
 protected:
  mav::SigningKey key_ = key_of(0);
  mav::SigningClock vehicle_clock_{1000000};
  mav::SigningClock ground_clock_{1000000};
  mav::Sender sender_{255, 190};
  mav::Signer signer_{key_, ground_clock_, 1};
  mav::SignatureVerifier verifier_{key_, vehicle_clock_};
};

}  // namespace

// A HEARTBEAT signed by node-mavlink 2.3.0 (MavLinkProtocolV2.sign(), key 00 01 .. 1f, link id 5,
// 2026-01-01 00:00:00 UTC): our signature computation and our signer reproduce it byte for byte.
TEST(SigningGolden, NodeMavlinkFrameReproduced) {
  const std::vector<uint8_t> node = {0xfd, 0x09, 0x01, 0x00, 0x07, 0x01, 0x01, 0x00, 0x00, 0x00, 0x04, 0x03,
                                     0x02, 0x01, 0x02, 0x03, 0x81, 0x04, 0x03, 0x1a, 0x5e, 0x05, 0x00, 0xe0,
                                     0x3c, 0xd6, 0x92, 0x1f, 0x1d, 0xdc, 0xe6, 0x51, 0x84, 0x38};
  const mav::SigningKey key = key_of(0);
  const uint64_t timestamp = mav::signing_timestamp_from_unix_microseconds(1767225600000000ull);
  EXPECT_EQ(timestamp, 34715520000000ull);
  EXPECT_EQ(timestamp_of(node), timestamp);

  mav::Heartbeat heartbeat;
  heartbeat.custom_mode = 0x01020304;
  heartbeat.type = 2;
  heartbeat.autopilot = 3;
  heartbeat.base_mode = 0x81;
  heartbeat.system_status = 4;
  mav::FrameHeader header;
  header.system_id = 1;
  header.component_id = 1;
  header.sequence = 7;
  header.incompat_flags = mav::kIncompatFlagSigned;
  std::vector<uint8_t> ours(mav::max_frame_length<mav::Heartbeat>(true));
  ours.resize(mav::encode(heartbeat, header, ours.data(), ours.size()));
  mav::SigningClock clock(timestamp);
  mav::Signer signer(key, clock, 5);
  ASSERT_TRUE(signer.sign(ours.data(), ours.size()));
  EXPECT_EQ(ours, node);

  mav::SigningClock vehicle(timestamp);
  mav::SignatureVerifier verifier(key, vehicle);
  verifier.set_require_signed(true);
  EXPECT_EQ(parse_and_check(node, verifier), std::vector<mav::SignatureCheck>{mav::SignatureCheck::kAcceptedSigned});
}

TEST(SigningTimestamp, UnixConversion) {
  EXPECT_EQ(mav::signing_timestamp_from_unix_microseconds(1420070400000000ull), 0u);
  EXPECT_EQ(mav::signing_timestamp_from_unix_microseconds(1420070400000010ull), 1u);
  EXPECT_EQ(mav::signing_timestamp_from_unix_microseconds(1420070401000000ull), 100000u);
  EXPECT_EQ(mav::signing_timestamp_from_unix_microseconds(0), 0u);  // before the epoch
}

TEST_F(Signing, RoundTripOfEveryMessageThroughTheParser) {
  std::mt19937_64 rng(7);
  std::vector<uint8_t> stream;
  size_t frames = 0;
  for (int round = 0; round < 5; ++round) {
    mav::for_each_message_type([&](auto prototype) {
      using Msg = decltype(prototype);
      const std::vector<uint8_t> f = signed_frame(sender_, signer_, mav::testing::random_message<Msg>(rng));
      stream.insert(stream.end(), f.begin(), f.end());
      ++frames;
    });
  }
  verifier_.set_require_signed(true);
  const std::vector<mav::SignatureCheck> outcomes = parse_and_check(stream, verifier_);
  ASSERT_EQ(outcomes.size(), frames);
  for (mav::SignatureCheck c : outcomes) EXPECT_EQ(c, mav::SignatureCheck::kAcceptedSigned);
  EXPECT_EQ(verifier_.stats().accepted_signed, frames);
  EXPECT_EQ(verifier_.stats().rejected(), 0u);
  EXPECT_EQ(verifier_.stream_count(), 1);
  // The vehicle's clock followed the ground's: its own next frames are not older than what it heard.
  EXPECT_EQ(vehicle_clock_.now(), ground_clock_.now() - 1);
}

TEST_F(Signing, TimestampsStrictlyIncreaseAndFollowTheClock) {
  uint64_t previous = 0;
  for (int i = 0; i < 50; ++i) {
    if (i == 25) ground_clock_.advance_to(5000000);       // real time known: jump forward
    if (i == 30) ground_clock_.advance_to(10);            // never backward
    const uint64_t t = timestamp_of(signed_frame(sender_, signer_, sensor_sample(i)));
    if (i == 0) EXPECT_EQ(t, 1000000u);
    if (i == 25) EXPECT_EQ(t, 5000000u);
    if (i > 0) EXPECT_GT(t, previous);
    previous = t;
  }
}

// Every single-bit change of a signed frame, in header, payload, CRC, link id, timestamp or signature, is
// rejected. Changes in header and payload get a recomputed CRC (what a forger does), so the parser
// delivers them and the signature alone must catch them; changes in the CRC bytes are handed to the
// verifier directly (the parser would drop them).
TEST_F(Signing, EveryBitFlipIsRejected) {
  const std::vector<uint8_t> original = signed_frame(sender_, signer_, sensor_sample(123456789));
  verifier_.set_require_signed(true);
  const size_t crc_at = original.size() - mav::kSignatureLength - mav::kChecksumLength;
  size_t through_parser = 0;
  for (size_t byte = 0; byte < original.size(); ++byte) {
    for (int bit = 0; bit < 8; ++bit) {
      std::vector<uint8_t> damaged = original;
      damaged[byte] = static_cast<uint8_t>(damaged[byte] ^ (1u << bit));
      mav::SigningClock clock(1000000);
      mav::SignatureVerifier verifier(key_, clock);
      verifier.set_require_signed(true);
      // Compat flags, sequence, system and component id, and the payload can be re-sent with a fixed CRC.
      // The start byte, length, incompat flags and message id change what the parser accepts, and the CRC
      // and signature block are what they are: those frames go to the verifier directly.
      const bool reparse = (byte >= 3 && byte <= 6) || (byte >= mav::kHeaderLength && byte < crc_at);
      mav::SignatureCheck outcome;
      if (reparse) {
        fix_crc(damaged, mav::HilSensor::kCrcExtra);
        const std::vector<mav::SignatureCheck> outcomes = parse_and_check(damaged, verifier);
        ASSERT_EQ(outcomes.size(), 1u) << "byte " << byte << " bit " << bit;
        outcome = outcomes[0];
        ++through_parser;
      } else {
        outcome = verifier.check(view(damaged));
      }
      const bool cleared_signed_flag = byte == 2 && bit == 0;
      EXPECT_EQ(outcome, cleared_signed_flag ? mav::SignatureCheck::kRejectedUnsigned : mav::SignatureCheck::kRejectedBadSignature)
          << "byte " << byte << " bit " << bit;
      EXPECT_EQ(verifier.stats().accepted_signed, 0u);
      EXPECT_EQ(clock.now(), 1000000u) << "a rejected frame moved the clock";
    }
  }
  EXPECT_GT(through_parser, 8u * 60u);
  EXPECT_EQ(verifier_.check(view(original)), mav::SignatureCheck::kAcceptedSigned);  // the original is fine
}

TEST_F(Signing, ReplayedAndReorderedFramesAreRejected) {
  verifier_.set_require_signed(true);
  const std::vector<uint8_t> first = signed_frame(sender_, signer_, sensor_sample(1));
  const std::vector<uint8_t> second = signed_frame(sender_, signer_, sensor_sample(2));
  EXPECT_EQ(verifier_.check(view(first)), mav::SignatureCheck::kAcceptedSigned);
  EXPECT_EQ(verifier_.check(view(first)), mav::SignatureCheck::kRejectedReplay);  // the same frame again
  EXPECT_EQ(verifier_.check(view(second)), mav::SignatureCheck::kAcceptedSigned);
  EXPECT_EQ(verifier_.check(view(first)), mav::SignatureCheck::kRejectedReplay);  // older than the last
  EXPECT_EQ(verifier_.check(view(second)), mav::SignatureCheck::kRejectedReplay);
  EXPECT_EQ(verifier_.stats().replayed, 3u);
  EXPECT_EQ(verifier_.stats().accepted_signed, 2u);

  // The same timestamp on another link, or from another component, is another stream.
  mav::SigningClock clock(1000000);
  mav::Signer radio(key_, clock, 2);
  mav::Sender camera(255, 100);
  mav::SigningClock same(1000000);
  mav::Signer camera_signer(key_, same, 1);
  EXPECT_EQ(verifier_.check(view(signed_frame(sender_, radio, sensor_sample(3)))), mav::SignatureCheck::kAcceptedSigned);
  EXPECT_EQ(verifier_.check(view(signed_frame(camera, camera_signer, sensor_sample(3)))), mav::SignatureCheck::kAcceptedSigned);
  EXPECT_EQ(verifier_.stream_count(), 3);
}

// A frame opening a new stream is accepted only if it is at most one minute behind the local clock.
TEST_F(Signing, NewStreamOlderThanOneMinuteIsRejected) {
  verifier_.set_require_signed(true);
  const uint64_t now = 50000000;  // 500 s after the epoch
  vehicle_clock_.advance_to(now);
  mav::SigningClock old_clock(now - mav::kNewStreamMaxAge - 1);
  mav::Signer old_signer(key_, old_clock, 3);
  EXPECT_EQ(verifier_.check(view(signed_frame(sender_, old_signer, sensor_sample(1)))), mav::SignatureCheck::kRejectedOldTimestamp);
  EXPECT_EQ(verifier_.stream_count(), 0);  // a rejected frame opens no stream
  // Exactly one minute behind: accepted, and from then on the stream only has to move forward.
  mav::SigningClock boundary_clock(now - mav::kNewStreamMaxAge);
  mav::Signer boundary(key_, boundary_clock, 3);
  EXPECT_EQ(verifier_.check(view(signed_frame(sender_, boundary, sensor_sample(2)))), mav::SignatureCheck::kAcceptedSigned);
  EXPECT_EQ(verifier_.check(view(signed_frame(sender_, boundary, sensor_sample(3)))), mav::SignatureCheck::kAcceptedSigned);
  EXPECT_EQ(verifier_.stats().old_timestamp, 1u);
  EXPECT_EQ(vehicle_clock_.now(), now);  // older accepted timestamps do not move the clock back
}

TEST_F(Signing, UnsignedFramesRejectedOnlyWhenSigningIsRequired) {
  const mav::HilSensor sample = sensor_sample(5);
  std::vector<uint8_t> plain(mav::max_frame_length<mav::HilSensor>());
  plain.resize(sender_.encode(sample, plain.data(), plain.size()));

  EXPECT_EQ(parse_and_check(plain, verifier_), std::vector<mav::SignatureCheck>{mav::SignatureCheck::kAcceptedUnsigned});
  verifier_.set_require_signed(true);
  EXPECT_EQ(parse_and_check(plain, verifier_), std::vector<mav::SignatureCheck>{mav::SignatureCheck::kRejectedUnsigned});

  // A policy lets chosen messages through unsigned (e.g. a radio modem's own frames), and only those.
  verifier_.set_unsigned_policy([](uint32_t id) { return id == mav::Heartbeat::kId; });
  std::vector<uint8_t> heartbeat(mav::max_frame_length<mav::Heartbeat>());
  heartbeat.resize(sender_.encode(mav::Heartbeat(), heartbeat.data(), heartbeat.size()));
  EXPECT_EQ(parse_and_check(heartbeat, verifier_), std::vector<mav::SignatureCheck>{mav::SignatureCheck::kAcceptedUnsigned});
  EXPECT_EQ(parse_and_check(plain, verifier_), std::vector<mav::SignatureCheck>{mav::SignatureCheck::kRejectedUnsigned});

  // Signing not required still checks signed frames: a wrong signature is a forgery either way.
  verifier_.set_require_signed(false);
  std::vector<uint8_t> forged = signed_frame(sender_, signer_, sample);
  forged.back() ^= 1;
  EXPECT_EQ(verifier_.check(view(forged)), mav::SignatureCheck::kRejectedBadSignature);

  const mav::SignatureStats& s = verifier_.stats();
  EXPECT_EQ(s.accepted_unsigned, 2u);
  EXPECT_EQ(s.rejected_unsigned, 2u);
  EXPECT_EQ(s.bad_signature, 1u);
  EXPECT_EQ(s.rejected(), 3u);
}

TEST_F(Signing, WrongKeyAndChangedKeyAreRejected) {
  verifier_.set_require_signed(true);
  const mav::SigningKey other = key_of(1);
  mav::SigningClock clock(2000000);
  mav::Signer stranger(other, clock, 1);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(verifier_.check(view(signed_frame(sender_, stranger, sensor_sample(i)))), mav::SignatureCheck::kRejectedBadSignature);
  }
  EXPECT_EQ(verifier_.stats().bad_signature, 10u);
  EXPECT_EQ(verifier_.stream_count(), 0);

  // Provisioning a new key at run time: the verifier and signer read the caller's key object.
  const std::vector<uint8_t> under_old_key = signed_frame(sender_, signer_, sensor_sample(1));
  std::memcpy(key_.bytes, other.bytes, sizeof key_.bytes);
  verifier_.forget_streams();
  EXPECT_EQ(verifier_.check(view(under_old_key)), mav::SignatureCheck::kRejectedBadSignature);
  EXPECT_EQ(verifier_.check(view(signed_frame(sender_, stranger, sensor_sample(2)))), mav::SignatureCheck::kAcceptedSigned);
  // Same key, sender and link id as `stranger`: the same stream, so it must be newer than stranger's.
  const std::vector<uint8_t> stale = signed_frame(sender_, signer_, sensor_sample(3));
  EXPECT_EQ(verifier_.check(view(stale)), mav::SignatureCheck::kRejectedReplay);
  ground_clock_.advance_to(clock.now());
  EXPECT_EQ(verifier_.check(view(signed_frame(sender_, signer_, sensor_sample(3)))), mav::SignatureCheck::kAcceptedSigned);
}

TEST_F(Signing, StreamTableFullRejectsNewStreamsButServesKnownOnes) {
  verifier_.set_require_signed(true);
  std::vector<mav::Sender> senders;
  for (uint8_t i = 0; i <= mav::SignatureVerifier::kMaxStreams; ++i) senders.emplace_back(10 + i, 1);
  for (uint8_t i = 0; i < mav::SignatureVerifier::kMaxStreams; ++i) {
    EXPECT_EQ(verifier_.check(view(signed_frame(senders[i], signer_, sensor_sample(i)))), mav::SignatureCheck::kAcceptedSigned);
  }
  EXPECT_EQ(verifier_.check(view(signed_frame(senders.back(), signer_, sensor_sample(0)))), mav::SignatureCheck::kRejectedTooManyStreams);
  EXPECT_EQ(verifier_.check(view(signed_frame(senders[0], signer_, sensor_sample(1)))), mav::SignatureCheck::kAcceptedSigned);
  EXPECT_EQ(verifier_.stats().too_many_streams, 1u);
  verifier_.forget_streams();
  EXPECT_EQ(verifier_.check(view(signed_frame(senders.back(), signer_, sensor_sample(0)))), mav::SignatureCheck::kAcceptedSigned);
}

TEST_F(Signing, SignerRefusesWhatItCannotSign) {
  // An unsigned frame (no reserved block), a truncated buffer, and a frame whose length byte disagrees.
  std::vector<uint8_t> plain(mav::max_frame_length<mav::HilSensor>(true));
  plain.resize(sender_.encode(sensor_sample(1), plain.data(), plain.size()));
  const std::vector<uint8_t> before = plain;
  EXPECT_FALSE(signer_.sign(plain.data(), plain.size()));
  EXPECT_EQ(plain, before);
  std::vector<uint8_t> reserved(mav::max_frame_length<mav::HilSensor>(true));
  reserved.resize(sender_.encode(sensor_sample(1), reserved.data(), reserved.size(), mav::kIncompatFlagSigned));
  EXPECT_FALSE(signer_.sign(reserved.data(), reserved.size() - 1));
  EXPECT_FALSE(signer_.sign(nullptr, reserved.size()));
  EXPECT_TRUE(signer_.sign(reserved.data(), reserved.size()));

  // The 48-bit timestamp is finite: an exhausted clock refuses to sign rather than wrap or repeat.
  mav::SigningClock end(mav::kMaxSigningTimestamp - 1);
  mav::Signer last(key_, end, 1);
  std::vector<uint8_t> out(mav::max_frame_length<mav::HilSensor>(true));
  EXPECT_GT(mav::encode_signed(sender_, last, sensor_sample(1), out.data(), out.size()), 0u);
  EXPECT_EQ(mav::encode_signed(sender_, last, sensor_sample(2), out.data(), out.size()), 0u);
  // Too small a buffer: nothing encoded.
  EXPECT_EQ(mav::encode_signed(sender_, signer_, sensor_sample(2), out.data(), out.size() - 1), 0u);
}
