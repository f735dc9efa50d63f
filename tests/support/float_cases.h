// Float test cases for code that works on bit patterns: the patterns themselves (by memcpy, independent
// of the code under test), specials, limits with their neighbours and random values.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <random>
#include <vector>

namespace quad_test {

inline uint32_t bits_of(float x) {
  uint32_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

inline float next_up(float x) { return std::nextafter(x, std::numeric_limits<float>::infinity()); }
inline float next_down(float x) { return std::nextafter(x, -std::numeric_limits<float>::infinity()); }

// Specials, the given limits and their neighbours (both signs), random patterns and random values.
inline std::vector<float> interesting_floats(std::initializer_list<float> limits, int random_count, uint32_t seed) {
  const float inf = std::numeric_limits<float>::infinity();
  std::vector<float> v = {0.0f, -0.0f, inf, -inf, std::numeric_limits<float>::quiet_NaN(),
                          -std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::denorm_min(),
                          std::numeric_limits<float>::max(), 1.0f, -1.0f};
  for (float l : limits) {
    for (float x : {l, next_up(l), next_down(l)}) {
      v.push_back(x);
      v.push_back(-x);
    }
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> small(-2.0f, 2.0f);
  for (int i = 0; i < random_count; ++i) {
    const uint32_t b = rng();
    float x;
    std::memcpy(&x, &b, sizeof x);
    v.push_back(x);
    const float l = *(limits.begin() + static_cast<int>(rng() % limits.size()));
    v.push_back(small(rng) * l);
  }
  return v;
}

inline bool same_float(float a, float b) { return (std::isnan(a) && std::isnan(b)) || bits_of(a) == bits_of(b); }

}  // namespace quad_test
