// Estimator replay on the ATmega2560 (tests/pil/test_estimator_agreement.cpp): the recorded sensor log
// in flash through the observer and the position filter, the estimates out on UART0 (1 Mbaud, polled),
// then sleep with interrupts off, which ends the simulation (simavr: cpu_Done).
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <avr/sleep.h>
#include <util/delay.h>

#include "replay_core.h"

namespace {

const quad::replay::Row kLog[] PROGMEM = {
#include "recorded_log.inc"
};

void put(char c) {
  while (!(UCSR0A & _BV(UDRE0))) {
  }
  UDR0 = static_cast<uint8_t>(c);
}

}  // namespace

int main() {
  UCSR0A = _BV(U2X0);
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);
  UBRR0 = 1;  // 1 Mbaud at 16 MHz with U2X
  UCSR0B = _BV(TXEN0);
  quad::replay::run(
      sizeof kLog / sizeof kLog[0],
      [](uint16_t i, quad::replay::Row& row) { memcpy_P(&row, &kLog[i], sizeof row); }, put);
  _delay_ms(1);  // the last bytes leave the shift register (10 us each)
  cli();
  sleep_enable();
  sleep_cpu();
}
