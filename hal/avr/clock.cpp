// Timer5 as the microsecond clock and idle()'s sleep: free-running at 2 MHz (0.5 us per tick, overflow
// every 32.768 ms), extended to 32 bits by counting overflows.
#include <avr/interrupt.h>
#include <avr/sleep.h>

#include "board.h"
#include "quad/hal/hal.h"

namespace {
volatile uint32_t g_overflows = 0;
}  // namespace

ISR(TIMER5_OVF_vect) { g_overflows = g_overflows + 1; }

// idle()'s deadline: only wakes the CPU; disarms itself.
ISR(TIMER5_COMPB_vect) { TIMSK5 &= static_cast<uint8_t>(~_BV(OCIE5B)); }

namespace quad {
namespace hal {
namespace avr {

void start_clock() {
  TCCR5A = 0;
  TCCR5B = _BV(CS51);  // normal mode, prescaler 8
  TIFR5 = _BV(TOV5);
  TIMSK5 |= _BV(TOIE5);
}

void wait_us(uint32_t us) {
  const uint32_t start = micros();
  while (micros() - start < us) {
  }
}

}  // namespace avr

uint32_t micros() {
  const uint8_t sreg = SREG;
  cli();
  uint32_t overflows = g_overflows;
  const uint16_t ticks = TCNT5;
  // An overflow that happened after cli() is pending, not yet counted: a small count means it wrapped.
  if ((TIFR5 & _BV(TOV5)) && ticks < 0x8000u) ++overflows;
  SREG = sreg;
  static_assert(avr::kTicksPerUs == 2, "the shift below assumes 2 ticks per microsecond");
  return (overflows << 15) + (ticks >> 1);
}

void idle(uint32_t max_wait_us) {
  // Sleep until any interrupt: a received byte, a timer. With interrupts off, check for bytes that
  // arrived since the caller last looked; sei() then takes effect only after `sleep`, so no interrupt
  // slips in between the check and the sleep.
  cli();
  if (avr::rx_pending()) {
    sei();
    return;
  }
  // Waits beyond one timer period end at the next overflow at the latest, which idle() allows.
  constexpr uint32_t kMaxCompareUs = 0xFFFFu / avr::kTicksPerUs;
  if (max_wait_us < kMaxCompareUs) {
    OCR5B = static_cast<uint16_t>(TCNT5 + static_cast<uint16_t>(max_wait_us * avr::kTicksPerUs));
    TIFR5 = _BV(OCF5B);
    TIMSK5 |= _BV(OCIE5B);
  }
  set_sleep_mode(SLEEP_MODE_IDLE);
  sleep_enable();
  sei();
  sleep_cpu();
  sleep_disable();
}

}  // namespace hal
}  // namespace quad
