// The timing both Cortex-M instruction-count images run the firmware's iteration with: its 400 Hz
// period, and vision fixes arriving 40 ms after their capture. Included once by each image's source.
#pragma once

#include <stdint.h>

namespace {

constexpr uint32_t kPeriodUs = 2500;  // 400 Hz
constexpr float kDt = 1e-6f * kPeriodUs;
constexpr uint32_t kFixDelayUs = 40000;

}  // namespace
