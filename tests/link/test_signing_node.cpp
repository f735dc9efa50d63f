// Signing against a real peer: frames node-mavlink signs (tools/node/signing_peer.js) verify in our
// SignatureVerifier with the same key and are rejected with another key, replayed or too old; frames our
// Signer signs verify in node-mavlink (MavLinkPacketSignature.matches) with the same key only.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "message_testing.h"
#include "node_peer.h"
#include "quad/link/mavlink.h"

namespace mav = quad::mavlink;

namespace {

using mav::testing::read_file;
using mav::testing::read_lines;
using SigningNode = mav::testing::NodePeerTest;

constexpr int kFrames = 300;
constexpr uint64_t kStartUnixMs = 1767225600000ull;  // 2026-01-01 00:00:00 UTC, node's first timestamp
const uint64_t kStart = mav::signing_timestamp_from_unix_microseconds(kStartUnixMs * 1000);

mav::SigningKey key_of(uint8_t seed) {
  mav::SigningKey key;
  std::mt19937 rng(seed);
  for (auto& b : key.bytes) b = static_cast<uint8_t>(rng());
  return key;
}

std::string hex(const mav::SigningKey& key) {
  std::ostringstream out;
  for (uint8_t b : key.bytes) out << "0123456789abcdef"[b >> 4] << "0123456789abcdef"[b & 15];
  return out.str();
}

uint64_t timestamp_of(const uint8_t* signature) {
  uint64_t t = 0;
  for (size_t i = 0; i < 6; ++i) t |= static_cast<uint64_t>(signature[mav::kSignatureTimestampOffset + i]) << (8 * i);
  return t;
}

struct Outcomes {
  std::vector<std::string> lines;  // SYSID COMPID LINKID TIMESTAMP of every frame delivered
  std::vector<mav::SignatureCheck> checks;
};

Outcomes parse_and_check(const std::string& bytes, mav::SignatureVerifier& verifier) {
  mav::Parser parser;
  Outcomes out;
  parser.feed(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), [&](const mav::Frame& f) {
    std::ostringstream line;
    line << +f.system_id << ' ' << +f.component_id;
    if (f.is_signed()) line << ' ' << +f.signature[mav::kSignatureLinkIdOffset] << ' ' << timestamp_of(f.signature);
    out.lines.push_back(line.str());
    out.checks.push_back(verifier.check(f));
  });
  EXPECT_EQ(parser.stats().bytes_discarded, 0u);
  return out;
}

size_t count(const std::vector<mav::SignatureCheck>& checks, mav::SignatureCheck which) {
  size_t n = 0;
  for (mav::SignatureCheck c : checks) n += c == which ? 1 : 0;
  return n;
}

}  // namespace

TEST_F(SigningNode, FramesSignedByNodeMavlinkVerifyWithTheKeyOnly) {
  const mav::SigningKey key = key_of(1);
  const std::string bin = dir_ + "/node_signed.bin";
  const std::string txt = dir_ + "/node_signed.txt";
  ASSERT_NO_FATAL_FAILURE(run_peer("signing_peer.js", "sign " + hex(key) + " 11 " + std::to_string(kFrames) + " " +
                                                          std::to_string(kStartUnixMs) + " '" + bin + "' '" + txt + "'"));
  const std::string bytes = read_file(bin);
  const std::vector<std::string> expected = read_lines(txt);
  ASSERT_EQ(expected.size(), static_cast<size_t>(kFrames));

  // The vehicle's clock 30 s ahead of the first frame: new streams are within the one-minute window.
  mav::SigningClock clock(kStart + 30 * mav::kSigningTicksPerSecond);
  mav::SignatureVerifier verifier(key, clock);
  verifier.set_require_signed(true);
  const Outcomes first = parse_and_check(bytes, verifier);
  EXPECT_EQ(first.lines, expected);  // link ids and timestamps as node-mavlink wrote them
  EXPECT_EQ(count(first.checks, mav::SignatureCheck::kAcceptedSigned), expected.size());
  EXPECT_EQ(verifier.stream_count(), 6);  // (link id, system, component) streams

  // The same bytes again: every frame is a replay.
  const Outcomes replay = parse_and_check(bytes, verifier);
  EXPECT_EQ(count(replay.checks, mav::SignatureCheck::kRejectedReplay), expected.size());

  // Another key: every frame has a bad signature, and none opens a stream.
  mav::SigningClock clock2(kStart);
  const mav::SigningKey other = key_of(2);
  mav::SignatureVerifier stranger(other, clock2);
  stranger.set_require_signed(true);
  EXPECT_EQ(count(parse_and_check(bytes, stranger).checks, mav::SignatureCheck::kRejectedBadSignature), expected.size());
  EXPECT_EQ(stranger.stream_count(), 0);

  // A vehicle whose clock is two minutes past the frames: recorded traffic cannot open streams.
  mav::SigningClock later(kStart + 120 * mav::kSigningTicksPerSecond);
  mav::SignatureVerifier late(key, later);
  EXPECT_EQ(count(parse_and_check(bytes, late).checks, mav::SignatureCheck::kRejectedOldTimestamp), expected.size());

  const mav::SignatureStats& s = verifier.stats();
  std::printf("node-signed frames: %u accepted, then %u replayed; wrong key: %u bad signature; "
              "clock 2 min ahead: %u old timestamp\n",
              s.accepted_signed, s.replayed, stranger.stats().bad_signature, late.stats().old_timestamp);
}

TEST_F(SigningNode, FramesWeSignVerifyInNodeMavlinkWithTheKeyOnly) {
  const mav::SigningKey key = key_of(3);
  mav::SigningClock clock(kStart);
  mav::Signer signers[] = {mav::Signer(key, clock, 0), mav::Signer(key, clock, 1), mav::Signer(key, clock, 7)};
  std::mt19937_64 rng(99);
  std::string bytes;
  std::vector<std::string> expected;         // node's verdicts with the right key
  std::vector<std::string> expected_other;   // and with another key
  size_t damaged = 0;
  while (expected.size() < static_cast<size_t>(kFrames)) {
    mav::for_each_message_type([&](auto prototype) {
      using Msg = decltype(prototype);
      // Six streams (system 1 or 2, three link ids), within the verifier's table of eight.
      mav::Sender sender(static_cast<uint8_t>(1 + rng() % 2), 190);
      mav::Signer& signer = signers[rng() % 3];
      uint8_t frame[mav::max_frame_length<Msg>(true)];
      const size_t size = mav::encode_signed(sender, signer, mav::testing::random_message<Msg>(rng), frame, sizeof frame);
      ASSERT_GT(size, 0u);
      const uint8_t* block = frame + size - mav::kSignatureLength;
      std::ostringstream line;
      line << +sender.system_id() << ' ' << +sender.component_id() << ' ' << +block[0] << ' ' << timestamp_of(block);
      // One frame in ten with a bit of the signature flipped (the CRC does not cover the block).
      const bool flip = rng() % 10 == 0;
      if (flip) {
        frame[size - 1 - rng() % mav::kSignatureHashLength] ^= static_cast<uint8_t>(1u << (rng() % 8));
        ++damaged;
      }
      expected.push_back(line.str() + (flip ? " bad" : " ok"));
      expected_other.push_back(line.str() + " bad");
      bytes.append(reinterpret_cast<const char*>(frame), size);
    });
  }
  const std::string bin = dir_ + "/ours.bin";
  std::ofstream(bin, std::ios::binary) << bytes;
  const std::string verdicts = dir_ + "/node_verdicts.txt";
  ASSERT_NO_FATAL_FAILURE(run_peer("signing_peer.js", "verify " + hex(key) + " '" + bin + "' '" + verdicts + "'"));
  EXPECT_EQ(read_lines(verdicts), expected);
  const std::string other = dir_ + "/node_verdicts_other_key.txt";
  ASSERT_NO_FATAL_FAILURE(run_peer("signing_peer.js", "verify " + hex(key_of(4)) + " '" + bin + "' '" + other + "'"));
  EXPECT_EQ(read_lines(other), expected_other);
  EXPECT_GT(damaged, 0u);

  // Our verifier agrees with node-mavlink on every frame.
  mav::SigningClock vehicle(kStart);
  mav::SignatureVerifier verifier(key, vehicle);
  verifier.set_require_signed(true);
  const Outcomes ours = parse_and_check(bytes, verifier);
  ASSERT_EQ(ours.checks.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    const bool node_ok = expected[i].size() > 3 && expected[i].compare(expected[i].size() - 3, 3, " ok") == 0;
    EXPECT_EQ(ours.checks[i], node_ok ? mav::SignatureCheck::kAcceptedSigned : mav::SignatureCheck::kRejectedBadSignature)
        << "frame " << i;
  }
  std::printf("our signed frames: %zu, node-mavlink accepts %zu, rejects the %zu with a flipped signature bit "
              "and all %zu under another key\n",
              expected.size(), expected.size() - damaged, damaged, expected_other.size());
}
