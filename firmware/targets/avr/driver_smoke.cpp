// Register-level smoke test of the APM 2.5 drivers on simavr (tests/pil/test_apm25_drivers.cpp): brings
// the board up as the flight image does (hal::init(), hal::avr::init_board()), sets four motor commands,
// signals that on GPIOR0, then reports on UART0 in frames that start with their type byte:
//   0xB0 r          once, after the bring-up: r = init_board()'s result (1: the MPU-6000 and the HMC5883L
//                   both answered, 0: at least one did not; init_board() does not say which)
//   0xA5 n p1..pn   every RC frame the PPM capture decodes: channel count n, pulse widths in us (16-bit
//                   little-endian)
//   0xB1 a.x a.y a.z g.x g.y g.z   every ImuSample imu_read() returns: accel m/s^2, gyro rad/s (FRD),
//                   six IEEE-754 single floats as the AVR stores them (little-endian)
//   0xB2 f.x f.y f.z               every MagSample mag_read() returns: field in gauss (FRD), three floats
// The test emulates the MPU-6000 (SPI) and the HMC5883L (TWI) or leaves the buses empty.
#include <avr/io.h>

#include "quad/hal/avr.h"
#include "quad/hal/hal.h"

namespace {

uint8_t* put(uint8_t* p, float v) {
  __builtin_memcpy(p, &v, sizeof v);
  return p + sizeof v;
}
uint8_t* put(uint8_t* p, const quad::Vec3& v) { return put(put(put(p, v.x), v.y), v.z); }

}  // namespace

int main() {
  quad::hal::init();
  const bool sensors = quad::hal::avr::init_board();
  const float command[quad::hal::kMotorCount] = {0.0f, 0.25f, 0.5f, 1.0f};
  quad::hal::motors_write(command);
  GPIOR0 = 1;
  const uint8_t init_frame[2] = {0xB0, sensors ? uint8_t{1} : uint8_t{0}};
  quad::hal::serial_write(quad::hal::kUart0, init_frame, sizeof init_frame);
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
    quad::hal::ImuSample imu;
    if (quad::hal::imu_read(imu)) {
      uint8_t out[1 + 6 * sizeof(float)] = {0xB1};
      put(put(out + 1, imu.accel), imu.gyro);
      quad::hal::serial_write(quad::hal::kUart0, out, sizeof out);
    }
    quad::hal::MagSample mag;
    if (quad::hal::mag_read(mag)) {
      uint8_t out[1 + 3 * sizeof(float)] = {0xB2};
      put(out + 1, mag.field);
      quad::hal::serial_write(quad::hal::kUart0, out, sizeof out);
    }
    quad::hal::idle(1000);
  }
}
