// Register-level smoke test of the APM 2.5 drivers on simavr (tests/pil/test_apm25_drivers.cpp): brings
// the board up as the flight image does (no MPU-6000 or HMC5883L answer on simavr), sets four motor
// commands, signals that on GPIOR0, then reports every RC frame the PPM capture decodes on UART0 as
// 0xA5, channel count, pulse widths (16-bit little-endian).
#include <avr/io.h>

#include "quad/hal/avr.h"
#include "quad/hal/hal.h"

int main() {
  quad::hal::init();
  quad::hal::avr::init_board();
  const float command[quad::hal::kMotorCount] = {0.0f, 0.25f, 0.5f, 1.0f};
  quad::hal::motors_write(command);
  GPIOR0 = 1;
  for (;;) {
    quad::hal::RcFrame frame;
    if (quad::hal::rc_read(frame)) {
      uint8_t out[2 + 2 * quad::hal::kRcChannels] = {0xA5, frame.count};
      for (uint8_t i = 0; i < frame.count; ++i) {
        out[2 + 2 * i] = static_cast<uint8_t>(frame.pulse_us[i]);
        out[3 + 2 * i] = static_cast<uint8_t>(frame.pulse_us[i] >> 8);
      }
      quad::hal::serial_write(quad::hal::kUart0, out, static_cast<uint16_t>(2 + 2 * frame.count));
    }
    quad::hal::idle(1000);
  }
}
