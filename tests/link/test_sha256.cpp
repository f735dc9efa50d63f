// SHA-256 against the NIST FIPS 180-4 example vectors and against an independent implementation (GNU
// coreutils' sha256sum) on random messages of every length around the padding boundaries.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "quad/link/sha256.h"

namespace mav = quad::mavlink;

namespace {

std::string hex(const uint8_t* data, size_t length) {
  std::ostringstream out;
  for (size_t i = 0; i < length; ++i) out << std::hex << std::setw(2) << std::setfill('0') << +data[i];
  return out.str();
}

std::string digest_of(const std::string& message) {
  uint8_t digest[mav::kSha256DigestLength];
  mav::sha256(reinterpret_cast<const uint8_t*>(message.data()), message.size(), digest);
  return hex(digest, sizeof digest);
}

// The same message fed in pieces of random sizes (0 included), crossing block boundaries anywhere.
std::string digest_in_pieces(const std::vector<uint8_t>& message, std::mt19937& rng) {
  mav::Sha256 hash;
  size_t offset = 0;
  while (offset < message.size()) {
    const size_t piece = std::min<size_t>(rng() % 150, message.size() - offset);
    hash.update(message.data() + offset, piece);
    offset += piece;
  }
  uint8_t digest[mav::kSha256DigestLength];
  hash.finish(digest);
  return hex(digest, sizeof digest);
}

}  // namespace

// FIPS 180-4 examples (NIST CSRC "Examples with intermediate values", SHA256.pdf and SHA2_Additional.pdf).
TEST(Sha256, NistVectors) {
  EXPECT_EQ(digest_of(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(digest_of("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(digest_of("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),  // 448 bits: two blocks
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(digest_of("abcdefghbcdefghicdefghijdefghijkefghijklfghijklmghijklmnhijklmnoijklmnopjklmnopqklmnopqrlmnopqrsmnopqrstnopqrstu"),
            "cf5b16a778af8380036ce59e7b0492370b249b11e8f07a51afac45037afee9d1");
  EXPECT_EQ(digest_of(std::string(1000000, 'a')), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Sha256, IncrementalUpdatesEqualOneShotAndObjectIsReusable) {
  std::mt19937 rng(42);
  mav::Sha256 reused;
  for (size_t length : {0u, 1u, 55u, 56u, 63u, 64u, 65u, 119u, 120u, 128u, 300u, 1000u}) {
    std::vector<uint8_t> message(length);
    for (auto& b : message) b = static_cast<uint8_t>(rng());
    uint8_t one_shot[mav::kSha256DigestLength];
    mav::sha256(message.data(), message.size(), one_shot);
    EXPECT_EQ(digest_in_pieces(message, rng), hex(one_shot, sizeof one_shot)) << "length " << length;
    uint8_t again[mav::kSha256DigestLength];
    reused.update(message.data(), message.size());
    reused.finish(again);  // finish() resets: the next message starts from H(0)
    EXPECT_EQ(hex(again, sizeof again), hex(one_shot, sizeof one_shot)) << "length " << length;
  }
}

TEST(Sha256, TruncatedDigestIsThePrefix) {
  const uint8_t message[] = {'a', 'b', 'c'};
  uint8_t full[mav::kSha256DigestLength];
  mav::sha256(message, sizeof message, full);
  for (size_t n : {1u, 3u, 6u, 7u, 31u}) {
    uint8_t part[mav::kSha256DigestLength];
    std::memset(part, 0xEE, sizeof part);
    mav::Sha256 hash;
    hash.update(message, sizeof message);
    hash.finish(part, n);
    EXPECT_EQ(hex(part, n), hex(full, n));
    EXPECT_EQ(part[n], 0xEE) << "wrote past " << n << " bytes";
  }
}

// 600 random messages (every length 0..199 around the one- and two-block padding cases, and longer random
// ones up to 2 kB) hashed by coreutils' sha256sum in one run and by ours, whole and in pieces.
TEST(Sha256, AgreesWithCoreutilsSha256sumOnRandomMessages) {
  char pattern[] = "/tmp/quad_sha256_XXXXXX";
  ASSERT_NE(mkdtemp(pattern), nullptr);
  const std::string dir = pattern;
  std::mt19937 rng(2015);
  std::map<std::string, std::vector<uint8_t>> messages;
  for (size_t i = 0; i < 600; ++i) {
    const size_t length = i < 200 ? i : rng() % 2048;
    std::vector<uint8_t> message(length);
    for (auto& b : message) b = static_cast<uint8_t>(rng());
    std::ostringstream name;
    name << dir << "/m" << std::setw(4) << std::setfill('0') << i;
    std::ofstream(name.str(), std::ios::binary).write(reinterpret_cast<const char*>(message.data()),
                                                      static_cast<std::streamsize>(message.size()));
    messages[name.str()] = message;
  }
  const std::string sums = dir + "/sums.txt";
  ASSERT_EQ(std::system(("sha256sum " + dir + "/m* > " + sums).c_str()), 0) << "sha256sum (coreutils) failed";
  std::ifstream in(sums);
  size_t checked = 0;
  for (std::string digest, path; in >> digest >> path;) {
    ASSERT_EQ(messages.count(path), 1u) << path;
    const std::vector<uint8_t>& message = messages[path];
    uint8_t ours[mav::kSha256DigestLength];
    mav::sha256(message.data(), message.size(), ours);
    EXPECT_EQ(hex(ours, sizeof ours), digest) << path << " (" << message.size() << " bytes)";
    EXPECT_EQ(digest_in_pieces(message, rng), digest) << path;
    ++checked;
  }
  EXPECT_EQ(checked, messages.size());
  if (!HasFailure()) std::system(("rm -rf '" + dir + "'").c_str());
}
