// hal::init() and the status LEDs of the APM 2.5 (board.h has the pin map).
#include <avr/interrupt.h>

#include "board.h"
#include "quad/hal/hal.h"

namespace quad {
namespace hal {
namespace avr {

// LEDs A, B, C on PA5, PA4, PA3, lit when the pin is low. A is the status LED of hal::led_write().
constexpr uint8_t kLedA = _BV(PA5), kLedB = _BV(PA4), kLedC = _BV(PA3);

void start_leds() {
  PORTA |= kLedA | kLedB | kLedC;  // off
  DDRA |= kLedA | kLedB | kLedC;
}

}  // namespace avr

void init() {
  cli();
  avr::start_leds();
  avr::start_clock();
  avr::start_uarts();
  sei();
}

void led_write(bool on) {
  // PORTA is in the I/O space: the compiler emits a single sbi/cbi, atomic against interrupts.
  if (on) PORTA &= static_cast<uint8_t>(~avr::kLedA);
  else PORTA |= avr::kLedA;
}

// GPIOR1 is free on this board (the cycle benchmarks' probes use GPIOR0 and GPIOR2).
void trace(TracePoint point) { GPIOR1 = static_cast<uint8_t>(point); }

}  // namespace hal
}  // namespace quad
