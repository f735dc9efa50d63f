// Parser robustness: 10 million bytes of noise, mutated frames and valid frames through one parser.
// Run under AddressSanitizer/UBSan by the host-debug preset: no crash, no out-of-bounds access, and every
// valid frame inside the garbage is found at its exact position.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <functional>
#include <random>
#include <vector>

#include "message_testing.h"
#include "quad/link/mavlink.h"

namespace mav = quad::mavlink;

namespace {

constexpr size_t kStreamBytes = 10u * 1000u * 1000u;

// CRC-16/MCRF4XX bit by bit: an implementation independent of the codec's byte-wise one.
uint16_t crc_bitwise(const uint8_t* data, size_t length, uint16_t crc) {
  for (size_t i = 0; i < length; ++i) {
    crc ^= data[i];
    for (int bit = 0; bit < 8; ++bit) crc = (crc & 1) ? static_cast<uint16_t>((crc >> 1) ^ 0x8408) : static_cast<uint16_t>(crc >> 1);
  }
  return crc;
}

// Checks a frame found in the stream from scratch: layout, known id, length, CRC with CRC_EXTRA.
bool independently_valid(const uint8_t* frame, size_t size) {
  if (size < 12 || frame[0] != 0xFD || (frame[2] & ~0x01) != 0) return false;
  const size_t expected = 12u + frame[1] + ((frame[2] & 0x01) ? 13u : 0u);
  const uint32_t id = frame[7] | (frame[8] << 8) | (static_cast<uint32_t>(frame[9]) << 16);
  mav::MessageInfo info{0, 0};
  if (size != expected || !mav::find_message_info(id, &info) || frame[1] > info.max_length) return false;
  uint16_t crc = crc_bitwise(frame + 1, 9u + frame[1], 0xFFFF);
  crc = crc_bitwise(&info.crc_extra, 1, crc);
  return frame[10 + frame[1]] == (crc & 0xFF) && frame[11 + frame[1]] == (crc >> 8);
}

struct Placed {
  size_t offset;
  size_t size;
};

class StreamBuilder {
 public:
  explicit StreamBuilder(uint64_t seed) : rng_(seed) {
    mav::for_each_message_type([&](auto prototype) {
      using Msg = decltype(prototype);
      makers_.push_back([this](const mav::FrameHeader& header) {
        const Msg msg = mav::testing::random_message<Msg>(rng_);
        std::vector<uint8_t> frame(mav::max_frame_length<Msg>(true));
        frame.resize(mav::encode(msg, header, frame.data(), frame.size()));
        return frame;
      });
    });
  }

  void build(size_t total) {
    while (stream_.size() < total) {
      const unsigned kind = rng_() % 10;
      if (kind < 4) {
        valid_.push_back({stream_.size(), 0});
        const std::vector<uint8_t> frame = random_frame();
        valid_.back().size = frame.size();
        append(frame);
      } else if (kind < 7) {
        append(mutated(random_frame()));
      } else {
        append(noise());
      }
    }
  }

  const std::vector<uint8_t>& stream() const { return stream_; }
  const std::vector<Placed>& valid() const { return valid_; }

 private:
  std::vector<uint8_t> random_frame() {
    mav::FrameHeader header;
    header.system_id = static_cast<uint8_t>(rng_() % 3);  // few senders: sequence tracking gets exercised
    header.component_id = 1;
    header.sequence = static_cast<uint8_t>(rng_());
    const bool is_signed = rng_() % 8 == 0;
    header.incompat_flags = is_signed ? mav::kIncompatFlagSigned : 0;
    std::vector<uint8_t> frame = makers_[rng_() % makers_.size()](header);
    if (is_signed) {  // the parser does not verify signatures: any block is carried through
      for (size_t i = frame.size() - mav::kSignatureLength; i < frame.size(); ++i) frame[i] = static_cast<uint8_t>(rng_());
    }
    return frame;
  }

  // A damaged frame: bit flips, a cut, an inserted or a deleted byte, or a forged length, always in the
  // bytes the CRC protects (the parser does not verify signatures, so a damaged signature block is still
  // a valid frame, and a signed frame cut inside its signature would take the next bytes as signature).
  std::vector<uint8_t> mutated(const std::vector<uint8_t>& original) {
    for (;;) {  // a forged length equal to the true one, or a bit flipped twice, would be no damage
      std::vector<uint8_t> damaged = damage(original);
      if (damaged != original) return damaged;
    }
  }

  std::vector<uint8_t> damage(std::vector<uint8_t> frame) {
    const size_t protected_end = frame.size() - ((frame[2] & mav::kIncompatFlagSigned) ? mav::kSignatureLength : 0);
    const auto position = [&] { return 1 + rng_() % (protected_end - 1); };
    switch (rng_() % 5) {
      case 0:
        for (int flips = 1 + static_cast<int>(rng_() % 3); flips > 0; --flips)
          frame[position()] ^= static_cast<uint8_t>(1u << (rng_() % 8));
        break;
      case 1:
        frame.resize(position());
        break;
      case 2:
        frame.insert(frame.begin() + static_cast<long>(position()), static_cast<uint8_t>(rng_()));
        break;
      case 3:
        frame.erase(frame.begin() + static_cast<long>(position()));
        break;
      default:
        frame[1] = static_cast<uint8_t>(rng_());
        break;
    }
    return frame;
  }

  // Random bytes, one in eight a start byte so that false starts are frequent.
  std::vector<uint8_t> noise() {
    std::vector<uint8_t> bytes(1 + rng_() % 300);
    for (uint8_t& b : bytes) b = rng_() % 8 == 0 ? mav::kStx : static_cast<uint8_t>(rng_());
    return bytes;
  }

  void append(const std::vector<uint8_t>& bytes) { stream_.insert(stream_.end(), bytes.begin(), bytes.end()); }

  std::mt19937_64 rng_;
  std::vector<std::function<std::vector<uint8_t>(const mav::FrameHeader&)>> makers_;
  std::vector<uint8_t> stream_;
  std::vector<Placed> valid_;
};

}  // namespace

TEST(ParserRobustness, TenMillionBytesOfNoiseAndMutatedFramesLoseNoValidFrame) {
  StreamBuilder builder(20261122);
  builder.build(kStreamBytes);
  const std::vector<uint8_t>& stream = builder.stream();
  ASSERT_GE(stream.size(), kStreamBytes);

  mav::Parser parser;
  std::vector<Placed> found;
  size_t accepted_bytes = 0;
  size_t max_held = 0;
  size_t invalid_found = 0;
  for (size_t i = 0; i < stream.size(); ++i) {
    parser.feed(stream[i], [&](const mav::Frame& frame) {
      // The frame ends where the bytes still held begin: locate it in the stream.
      const size_t end = i + 1 - parser.held_bytes();
      const size_t start = end - frame.size;
      found.push_back({start, frame.size});
      accepted_bytes += frame.size;
      if (!std::equal(frame.bytes, frame.bytes + frame.size, stream.begin() + static_cast<long>(start)) ||
          !independently_valid(frame.bytes, frame.size)) {
        ++invalid_found;
      }
    });
    max_held = std::max(max_held, parser.held_bytes());
  }

  // Every inserted valid frame is found at its exact offset. A damaged frame can still be valid by
  // chance: its CRC matches (1 in 65536), or a frame cut inside its CRC is completed by the byte that
  // follows (1 in 256 of those cuts). Such a frame is found (an "extra") and may overlap the genuine frame
  // after it, which is then lost for any parser ("shadowed"); nothing else may lose a frame.
  size_t next_found = 0;
  size_t matched = 0;
  size_t shadowed = 0;
  for (const Placed& v : builder.valid()) {
    while (next_found < found.size() && found[next_found].offset < v.offset) ++next_found;
    if (next_found < found.size() && found[next_found].offset == v.offset && found[next_found].size == v.size) {
      ++matched;
      continue;
    }
    const bool overlapped = next_found > 0 && found[next_found - 1].offset + found[next_found - 1].size > v.offset;
    if (overlapped) {
      ++shadowed;
    } else {
      ADD_FAILURE() << "valid frame at offset " << v.offset << " (" << v.size << " bytes) not found";
    }
  }
  const size_t extra = found.size() - matched;
  const mav::ParserStats& stats = parser.stats();
  std::printf("stream %zu bytes: %zu valid frames inserted, %zu found at their offsets, %zu shadowed by a chance "
              "frame, %zu extra accepted (damaged frames valid by chance)\n"
              "discarded %u bytes; rejected: %u bad CRC, %u unknown id, %u bad length, %u unsupported flags; "
              "max held %zu bytes\n",
              stream.size(), builder.valid().size(), matched, shadowed, extra, stats.bytes_discarded,
              stats.bad_checksum, stats.unknown_message, stats.bad_length, stats.unsupported_flags, max_held);

  EXPECT_EQ(invalid_found, 0u) << "a reported frame does not match the stream or is not a valid frame";
  EXPECT_GT(builder.valid().size(), 40000u);
  EXPECT_EQ(matched + shadowed, builder.valid().size());
  // About 2e4 CRC checks and 4e3 cuts inside a CRC give a handful of chance frames; far more would mean
  // a parser bug.
  EXPECT_LE(extra, 10u);
  EXPECT_LE(shadowed, extra);
  EXPECT_LE(max_held, mav::kMaxFrameLength);
  EXPECT_EQ(accepted_bytes + stats.bytes_discarded + parser.held_bytes(), stream.size());
  EXPECT_GT(stats.bad_checksum, 10000u);
  EXPECT_GT(stats.unknown_message, 10000u);
}
