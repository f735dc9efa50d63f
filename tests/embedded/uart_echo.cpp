// UART echo image for the avr_pil bridge test: every byte received on UART0 or UART2 is sent back on
// the same port. Register-level on purpose (it tests the bridge, not the HAL): U2X and the frame format
// are set before UBRR, as simavr needs to time the UART correctly.
#include <avr/io.h>
#include <stdint.h>

namespace {
constexpr uint16_t kUbrr = 3;  // 500 000 baud at 16 MHz with U2X (exact)

void init_uart0() {
  UCSR0A = _BV(U2X0);
  UCSR0C = _BV(UCSZ01) | _BV(UCSZ00);  // 8N1
  UBRR0 = kUbrr;
  UCSR0B = _BV(RXEN0) | _BV(TXEN0);
}
void init_uart2() {
  UCSR2A = _BV(U2X2);
  UCSR2C = _BV(UCSZ21) | _BV(UCSZ20);
  UBRR2 = kUbrr;
  UCSR2B = _BV(RXEN2) | _BV(TXEN2);
}

// Bytes wait in a ring while the transmitter is busy, so reception is never blocked by transmission.
struct Ring {
  uint8_t buf[256];
  uint8_t head = 0, tail = 0;
  bool empty() const { return head == tail; }
  void push(uint8_t b) { buf[head++] = b; }
  uint8_t pop() { return buf[tail++]; }
};
Ring r0, r2;
}  // namespace

int main() {
  init_uart0();
  init_uart2();
  for (;;) {
    if (UCSR0A & _BV(RXC0)) r0.push(UDR0);
    if (UCSR2A & _BV(RXC2)) r2.push(UDR2);
    if (!r0.empty() && (UCSR0A & _BV(UDRE0))) UDR0 = r0.pop();
    if (!r2.empty() && (UCSR2A & _BV(UDRE2))) UDR2 = r2.pop();
  }
}
