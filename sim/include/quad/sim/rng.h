// Seeded random numbers. Every random process in the simulator owns its own stream, derived from the
// scenario seed and a fixed stream name, so adding draws to one model never changes another's sequence.
#pragma once

#include <cstdint>
#include <random>
#include <string_view>

namespace quad::sim {

class Rng {
 public:
  Rng(uint64_t seed, std::string_view stream) : engine_(mix(seed, stream)) {}

  double normal(double stddev = 1.0) { return stddev * normal_(engine_); }
  double uniform(double lo = 0.0, double hi = 1.0) { return lo + (hi - lo) * uniform_(engine_); }
  bool bernoulli(double p) { return p > 0.0 && uniform_(engine_) < p; }
  // Number of failures before the first success in Bernoulli trials of probability p (p > 0).
  uint64_t geometric(double p) { return std::geometric_distribution<uint64_t>(p)(engine_); }

 private:
  static uint64_t mix(uint64_t seed, std::string_view stream) {
    uint64_t h = 1469598103934665603ull;  // FNV-1a over the stream name, then splitmix64 with the seed
    for (char c : stream) h = (h ^ static_cast<unsigned char>(c)) * 1099511628211ull;
    uint64_t z = seed + 0x9e3779b97f4a7c15ull * (h | 1u);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }

  std::mt19937_64 engine_;
  std::normal_distribution<double> normal_{0.0, 1.0};
  std::uniform_real_distribution<double> uniform_{0.0, 1.0};
};

}  // namespace quad::sim
