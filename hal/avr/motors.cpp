// ESC outputs OUT1..OUT4 of the APM 2.5 at 490 Hz: Timer1 (OC1B PB6, OC1A PB5) and Timer4 (OC4C PH5,
// OC4B PH4) in fast PWM mode 14 (TOP = ICRn) at 2 MHz, pulses 1000 us (stopped) to 2000 us (full).
#include "board.h"
#include "quad/hal/hal.h"

namespace quad {
namespace hal {
namespace avr {
namespace {

constexpr uint16_t kTop = static_cast<uint16_t>(kTimer5Hz / 490u - 1u);  // 4081: 490.0 Hz
constexpr uint16_t kMinPulseUs = 1000, kMaxPulseUs = 2000;

uint16_t compare_value(float command) {
  const float c = command > 0.0f ? (command < 1.0f ? command : 1.0f) : 0.0f;  // NaN -> 0 (stopped)
  const uint16_t us = static_cast<uint16_t>(kMinPulseUs + c * static_cast<float>(kMaxPulseUs - kMinPulseUs) + 0.5f);
  return static_cast<uint16_t>(us * kTicksPerUs);
}

}  // namespace

void start_motors() {
  const uint16_t stop = compare_value(0.0f);
  // Timer1: WGM = 14 (WGM13:12 in B, WGM11 in A), non-inverting on A and B, prescaler 8.
  ICR1 = kTop;
  OCR1A = stop;
  OCR1B = stop;
  TCCR1A = _BV(COM1A1) | _BV(COM1B1) | _BV(WGM11);
  TCCR1B = _BV(WGM13) | _BV(WGM12) | _BV(CS11);
  DDRB |= _BV(PB5) | _BV(PB6);
  // Timer4: same, outputs B and C.
  ICR4 = kTop;
  OCR4B = stop;
  OCR4C = stop;
  TCCR4A = _BV(COM4B1) | _BV(COM4C1) | _BV(WGM41);
  TCCR4B = _BV(WGM43) | _BV(WGM42) | _BV(CS41);
  DDRH |= _BV(PH4) | _BV(PH5);
}

}  // namespace avr

void motors_write(const float (&command)[kMotorCount]) {
  // No interrupt touches Timer1/Timer4, so the 16-bit writes (through the shared TEMP register) are safe.
  OCR1B = avr::compare_value(command[0]);  // OUT1
  OCR1A = avr::compare_value(command[1]);  // OUT2
  OCR4C = avr::compare_value(command[2]);  // OUT3
  OCR4B = avr::compare_value(command[3]);  // OUT4
}

}  // namespace hal
}  // namespace quad
