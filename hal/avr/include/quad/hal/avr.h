// APM 2.5 specifics the board image needs beyond hal.h.
#pragma once

#include <stdint.h>

namespace quad {
namespace hal {
namespace avr {

// Starts the board's sensors and actuators after hal::init(): MPU-6000, HMC5883L, ESC outputs (at
// 1000 us, motors stopped) and the PPM input. Returns false when a sensor does not answer; the
// drivers of a missing sensor then report no samples, which the application's health check sees.
bool init_board();

}  // namespace avr
}  // namespace hal
}  // namespace quad
