// Deterministic sensor noise for the benchmark images (AVR cycle benches, Cortex-M instruction counts):
// a linear congruential generator, the same sequence in every image, scaled by a volatile factor so the
// compiler cannot fold the benchmarked arithmetic away. Freestanding; one image includes it once.
#pragma once

#include <stdint.h>

namespace quad_bench {

inline volatile float& noise_scale() {
  static volatile float scale = 1.0f;
  return scale;
}

// Uniform in [-amplitude, amplitude).
inline float noise(float amplitude) {
  static uint32_t seed = 12345u;
  seed = seed * 1664525u + 1013904223u;
  return amplitude * noise_scale() *
         (static_cast<float>(static_cast<int32_t>(seed >> 8) - 8388608L) * (1.0f / 8388608.0f));
}

}  // namespace quad_bench
