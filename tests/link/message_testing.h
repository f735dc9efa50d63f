// Test helpers for the link codec: random message values and byte-exact message comparison.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>
#include <type_traits>
#include <vector>

#include "quad/link/mavlink.h"

namespace quad {
namespace mavlink {
namespace testing {

// Fills every field with random values: integers from random bits, floats from random bits (finite
// only, including subnormals and -0), strings of random printable length (NUL-padded, possibly full).
class RandomFiller {
 public:
  explicit RandomFiller(std::mt19937_64& rng) : rng_(rng) {}

  template <class T>
  void operator()(T& value) {
    static_assert(std::is_integral<T>::value, "unhandled field type");
    value = static_cast<T>(rng_());
  }
  void operator()(float& value) {
    do {
      const auto bits = static_cast<uint32_t>(rng_());
      std::memcpy(&value, &bits, sizeof value);
    } while (!std::isfinite(value));
  }
  template <size_t N>
  void operator()(char (&text)[N]) {
    const size_t length = rng_() % (N + 1);
    for (size_t i = 0; i < N; ++i) text[i] = i < length ? static_cast<char>(32 + rng_() % 95) : '\0';
  }
  template <class T, size_t N>
  void operator()(T (&values)[N]) {
    for (T& v : values) (*this)(v);
  }
  void extensions() {}

 private:
  std::mt19937_64& rng_;
};

template <class Msg>
Msg random_message(std::mt19937_64& rng) {
  Msg msg;
  RandomFiller filler(rng);
  Msg::fields(msg, filler);
  return msg;
}

// The full, untruncated payload of a message: equal payloads mean bit-identical field values.
template <class Msg>
std::vector<uint8_t> payload_of(const Msg& msg) {
  std::vector<uint8_t> bytes(Msg::kLength);
  wire::Writer writer(bytes.data());
  Msg::fields(msg, writer);
  return bytes;
}

}  // namespace testing
}  // namespace mavlink
}  // namespace quad
