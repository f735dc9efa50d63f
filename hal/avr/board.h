// APM 2.5 (ATmega2560 at 16 MHz): where the parts sit, as ArduPilot's APM2 board support wires them.
// Private to hal/avr; docs/targets.md has the same table for people.
//
//   MPU-6000 (SPI)        CS PB0 (Arduino pin 53), SCK PB1, MOSI PB2, MISO PB3; data-ready PE6 (unused:
//                         the driver reads INT_STATUS in the same burst as the sample)
//   other SPI devices     MS5611 baro CS PG1 (pin 40), DataFlash CS PA6 (pin 28): held high (deselected)
//   HMC5883L (I2C)        TWI: SCL PD0, SDA PD1, 7-bit address 0x1E (the external 3DR compass)
//   ESC outputs           OUT1 PB6 (OC1B), OUT2 PB5 (OC1A), OUT3 PH5 (OC4C), OUT4 PH4 (OC4B)
//   PPM-sum input         PL1 (ICP5), from the board's ATmega32U2 PPM encoder
//   LEDs (active low)     A PA5 (pin 27), B PA4 (pin 26), C PA3 (pin 25)
//   UART0                 the USB port (ATmega32U2 bridge); UART2 the telemetry radio header
#pragma once

#include <avr/io.h>
#include <stdint.h>

namespace quad {
namespace hal {
namespace avr {

// Timer5 runs free at F_CPU / 8 = 2 MHz: the microsecond clock, idle()'s wake-up and the PPM capture
// share it (hal/avr/clock.cpp, rc_ppm.cpp).
constexpr uint32_t kTimer5Hz = 2000000u;
constexpr uint8_t kTicksPerUs = static_cast<uint8_t>(kTimer5Hz / 1000000u);

// Bring-up steps of hal::init().
void start_clock();
void start_uarts();
void start_leds();

// True while a received byte waits in a UART ring (uart.cpp); called with interrupts disabled.
bool rx_pending();

// Busy-waits (interrupts keep running): for the sensors' power-up delays.
void wait_us(uint32_t us);

}  // namespace avr
}  // namespace hal
}  // namespace quad
