// Byte compatibility with a real peer: node-mavlink (tools/node/mavlink_peer.js) encodes every message
// with random values and our parser must decode them exactly; our encoder's frames must be decoded by
// node-mavlink to the same values. Values are compared as text lines in the format mavlink_peer.js
// documents (floats as their exact bit patterns), in wire order, so a wrong field order, type, length,
// CRC_EXTRA or truncation rule on either side fails the test.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>

#include "message_testing.h"
#include "node_peer.h"
#include "quad/link/mavlink.h"

namespace mav = quad::mavlink;

namespace {

// Formats field values like mavlink_peer.js does.
class LineFormatter {
 public:
  explicit LineFormatter(std::ostringstream& out) : out_(out) {}
  template <class T>
  void operator()(const T& value) {
    static_assert(std::is_integral<T>::value, "unhandled field type");
    out_ << ' ' << +value;
  }
  void operator()(const float& value) {
    uint32_t bits;
    std::memcpy(&bits, &value, sizeof bits);
    out_ << ' ' << std::hex << std::setw(8) << std::setfill('0') << bits << std::dec;
  }
  template <size_t N>
  void operator()(const char (&text)[N]) {
    out_ << ' ';
    if (N == 0 || text[0] == '\0') {
      out_ << '-';
      return;
    }
    for (size_t i = 0; i < N && text[i] != '\0'; ++i)
      out_ << std::hex << std::setw(2) << std::setfill('0') << (static_cast<unsigned>(text[i]) & 0xFF) << std::dec;
  }
  template <class T, size_t N>
  void operator()(const T (&values)[N]) {
    for (const T& v : values) (*this)(v);
  }
  void extensions() {}

 private:
  std::ostringstream& out_;
};

template <class Msg>
std::string format_line(const Msg& msg, uint8_t sequence, uint8_t system_id, uint8_t component_id,
                        const uint8_t* signature) {
  std::ostringstream out;
  out << Msg::kName << ' ' << +sequence << ' ' << +system_id << ' ' << +component_id;
  LineFormatter formatter(out);
  Msg::fields(msg, formatter);
  if (signature != nullptr) {
    out << " sig=";
    for (size_t i = 0; i < mav::kSignatureLength; ++i) out << std::hex << std::setw(2) << std::setfill('0') << +signature[i];
  }
  return out.str();
}

// Sets every field from index `from` on to zero (payload truncation on the wire).
class ZeroTail {
 public:
  explicit ZeroTail(size_t from) : from_(from) {}
  template <class T>
  void operator()(T& field) {
    if (index_++ >= from_) std::memset(&field, 0, sizeof field);
  }
  void extensions() {}
  size_t count() const { return index_; }

 private:
  size_t from_;
  size_t index_ = 0;
};

using NodeConformance = mav::testing::NodePeerTest;
using mav::testing::read_file;
using mav::testing::read_lines;

}  // namespace

TEST_F(NodeConformance, FramesEncodedByNodeMavlinkDecodeExactly) {
  const std::string bin = dir_ + "/node.bin";
  const std::string txt = dir_ + "/node.txt";
  ASSERT_NO_FATAL_FAILURE(run_peer("mavlink_peer.js", "encode 5150 60 '" + bin + "' '" + txt + "'"));
  const std::vector<std::string> expected = read_lines(txt);
  const std::string bytes = read_file(bin);
  size_t types = 0;
  mav::for_each_message_type([&](auto) { ++types; });
  ASSERT_EQ(types, 28u);
  ASSERT_EQ(expected.size(), 60u * types);

  mav::Parser parser;
  std::vector<std::string> decoded;
  size_t signed_frames = 0;
  size_t truncated_frames = 0;
  parser.feed(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(), [&](const mav::Frame& frame) {
    size_t matches = 0;
    mav::for_each_message_type([&](auto prototype) {
      using Msg = decltype(prototype);
      Msg msg;
      if (!mav::decode(frame, msg)) return;
      ++matches;
      if (frame.payload_length < Msg::kLength) ++truncated_frames;
      decoded.push_back(format_line(msg, frame.sequence, frame.system_id, frame.component_id, frame.signature));
    });
    EXPECT_EQ(matches, 1u) << "message id " << frame.message_id;
    if (frame.is_signed()) ++signed_frames;
  });

  ASSERT_EQ(decoded.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(decoded[i], expected[i]) << "frame " << i;
  const mav::ParserStats& stats = parser.stats();
  EXPECT_EQ(stats.bytes_discarded, 0u);
  EXPECT_EQ(stats.frames_accepted, expected.size());
  EXPECT_EQ(parser.held_bytes(), 0u);
  EXPECT_GT(signed_frames, 0u);     // the signature block is located and exposed
  EXPECT_GT(truncated_frames, 0u);  // zero-extension is exercised
}

TEST_F(NodeConformance, FramesWeEncodeDecodeInNodeMavlinkToTheSameValues) {
  std::mt19937_64 rng(1979);
  std::string bytes;
  std::vector<std::string> expected;
  size_t signed_frames = 0;
  for (int round = 0; round < 60; ++round) {
    mav::for_each_message_type([&](auto prototype) {
      using Msg = decltype(prototype);
      Msg msg = mav::testing::random_message<Msg>(rng);
      if (rng() % 4 == 0) {  // a zero tail, truncated on the wire
        ZeroTail count(~size_t{0});
        Msg::fields(msg, count);
        ZeroTail zero(rng() % count.count());
        Msg::fields(msg, zero);
      }
      mav::FrameHeader header;
      header.system_id = static_cast<uint8_t>(rng());
      header.component_id = static_cast<uint8_t>(rng());
      header.sequence = static_cast<uint8_t>(expected.size());
      // An eighth signed: the block the encoder reserves is filled as a signing layer would.
      const bool is_signed = rng() % 8 == 0;
      header.incompat_flags = is_signed ? mav::kIncompatFlagSigned : 0;
      uint8_t frame[mav::max_frame_length<Msg>(true)];
      const size_t size = mav::encode(msg, header, frame, sizeof frame);
      ASSERT_GT(size, 0u);
      const uint8_t* signature = nullptr;
      if (is_signed) {
        signature = frame + size - mav::kSignatureLength;
        for (size_t i = size - mav::kSignatureLength; i < size; ++i) frame[i] = static_cast<uint8_t>(rng());
        ++signed_frames;
      }
      bytes.append(reinterpret_cast<const char*>(frame), size);
      expected.push_back(format_line(msg, header.sequence, header.system_id, header.component_id, signature));
    });
  }
  const std::string bin = dir_ + "/ours.bin";
  const std::string txt = dir_ + "/ours_decoded_by_node.txt";
  std::ofstream(bin, std::ios::binary) << bytes;
  ASSERT_NO_FATAL_FAILURE(run_peer("mavlink_peer.js", "decode '" + bin + "' '" + txt + "'"));
  const std::vector<std::string> decoded = read_lines(txt);
  ASSERT_EQ(decoded.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(decoded[i], expected[i]) << "frame " << i;
  EXPECT_GT(signed_frames, 0u);
}
