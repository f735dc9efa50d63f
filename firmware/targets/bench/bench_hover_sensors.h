// Sensor samples of a slowly rocking vehicle near hover for the flight-core benchmark images (AVR cycle
// bench, Cortex-M instruction count): rates of a few deg/s, specific force near -g e_z, the earth field,
// each with bench_noise.h's noise. Freestanding; one image includes it once.
#pragma once

#include <stdint.h>

#include "quad/math/math.h"
#include "bench_noise.h"

namespace quad_bench {
// Internal linkage, as a function of the image's own source: declared `inline` it is inlined otherwise
// and the measured figures move.
namespace {

struct Sensors {
  quad::Vec3 gyro, accel, mag;
};

// Sample k; the rocking repeats every 300 samples. Draws nine values from noise() in a fixed order, so
// the images see the same sequence.
Sensors hover_sample(uint32_t k) {
  const float phase = 0.02f * static_cast<float>(k % 300u) - 3.0f;
  Sensors s;
  s.gyro = quad::Vec3{0.05f * phase + noise(0.01f), -0.03f + noise(0.01f), 0.02f + noise(0.01f)};
  s.accel = quad::Vec3{0.3f + noise(0.2f), -0.2f + noise(0.2f), -quad::kGravity + noise(0.2f)};
  s.mag = quad::Vec3{0.21f + noise(0.005f), 0.02f + noise(0.005f), 0.43f + noise(0.005f)};
  return s;
}

}  // namespace
}  // namespace quad_bench
