// UART0 (USB, HIL and telemetry) and UART2 (radio): interrupt-driven, a ring buffer each way.
//
// Reception must keep up with back-to-back bytes while the flight iteration runs (a HIL_SENSOR frame
// arrives in one burst, and simavr delivers received bytes about twice as fast as the baud rate), so
// the receive interrupt only stores the byte. Transmission queues what fits (hal.h contract; the
// application counts the rest as dropped) and the data-register-empty interrupt drains the ring.
#include <avr/interrupt.h>

#include "board.h"
#include "quad/hal/hal.h"

namespace quad {
namespace hal {
namespace avr {
namespace {

// Power-of-two ring with 8-bit indices: one producer and one consumer, the interrupt being one of them.
template <uint16_t kSize>
struct Ring {
  static_assert(kSize >= 2 && kSize <= 256 && (kSize & (kSize - 1)) == 0, "ring size: power of two <= 256");
  static constexpr uint8_t kMask = static_cast<uint8_t>(kSize - 1);
  uint8_t data[kSize];
  volatile uint8_t head = 0;  // next write
  volatile uint8_t tail = 0;  // next read
  bool empty() const { return head == tail; }
  uint8_t used() const { return static_cast<uint8_t>(head - tail) & kMask; }
  uint8_t free_space() const { return static_cast<uint8_t>(kMask - used()); }
  bool push(uint8_t b) {
    const uint8_t next = static_cast<uint8_t>((head + 1) & kMask);
    if (next == tail) return false;
    data[head] = b;
    head = next;
    return true;
  }
  uint8_t pop() {
    const uint8_t b = data[tail];
    tail = static_cast<uint8_t>((tail + 1) & kMask);
    return b;
  }
};

// The register block of USART n starts at kBase: UCSRnA, UCSRnB, UCSRnC, -, UBRRnL, UBRRnH, UDRn.
template <uint16_t kBase, uint32_t kBaud, uint16_t kRxSize, uint16_t kTxSize>
struct Usart {
  static volatile uint8_t& ucsra() { return _SFR_MEM8(kBase + 0); }
  static volatile uint8_t& ucsrb() { return _SFR_MEM8(kBase + 1); }
  static volatile uint8_t& ucsrc() { return _SFR_MEM8(kBase + 2); }
  static volatile uint16_t& ubrr() { return _SFR_MEM16(kBase + 4); }
  static volatile uint8_t& udr() { return _SFR_MEM8(kBase + 6); }
  // Same bit positions in every USART of the ATmega2560.
  static constexpr uint8_t kRxcie = 7, kUdrie = 5, kRxen = 4, kTxen = 3, kU2x = 1, kUcsz1 = 2, kUcsz0 = 1;

  Ring<kRxSize> rx;
  Ring<kTxSize> tx;

  void start() {
    // Double speed, 8N1, then the divider: simavr derives the UART's timing when UBRR is written.
    ucsra() = _BV(kU2x);
    ucsrc() = _BV(kUcsz1) | _BV(kUcsz0);
    constexpr uint32_t kUbrr = (F_CPU + 4u * kBaud) / (8u * kBaud) - 1u;  // rounded to nearest
    static_assert(kUbrr <= 4095u, "baud rate too low for U2X");
    ubrr() = static_cast<uint16_t>(kUbrr);
    ucsrb() = _BV(kRxcie) | _BV(kRxen) | _BV(kTxen);
  }
  // A byte that finds the ring full is dropped; the MAVLink parser then rejects that frame by its CRC.
  void on_receive() { rx.push(udr()); }
  void on_data_register_empty() {
    if (tx.empty()) {
      ucsrb() &= static_cast<uint8_t>(~_BV(kUdrie));
    } else {
      udr() = tx.pop();
    }
  }
  uint16_t read(uint8_t* dst, uint16_t capacity) {
    uint16_t n = 0;
    while (n < capacity && !rx.empty()) dst[n++] = rx.pop();
    return n;
  }
  uint16_t write(const uint8_t* src, uint16_t length) {
    const uint16_t room = tx.free_space();
    const uint16_t n = length < room ? length : room;
    for (uint16_t i = 0; i < n; ++i) tx.push(src[i]);
    if (n > 0) ucsrb() |= _BV(kUdrie);  // the caller holds interrupts off (the ISR clears this bit)
    return n;
  }
};

// UART0: 1 Mbaud, exact at 16 MHz with U2X (UBRR 1); the USB bridge and the PIL pseudo-terminal take it.
// UART2: 57600 baud (UBRR 34, -0.8 %), the 3DR radio's default.
Usart<0xC0, 1000000u, 256, 256> g_uart0;
Usart<0xD0, 57600u, 128, 128> g_uart2;

}  // namespace

void start_uarts() {
  g_uart0.start();
  g_uart2.start();
}

bool rx_pending() { return !g_uart0.rx.empty() || !g_uart2.rx.empty(); }

}  // namespace avr

uint16_t serial_read(Port port, uint8_t* dst, uint16_t capacity) {
  return port == kUart0 ? avr::g_uart0.read(dst, capacity) : avr::g_uart2.read(dst, capacity);
}

uint16_t serial_write(Port port, const uint8_t* src, uint16_t length) {
  // UCSRnB is also written by the ISR (clearing UDRIE): keep the read-modify-write atomic.
  const uint8_t sreg = SREG;
  cli();
  const uint16_t n = port == kUart0 ? avr::g_uart0.write(src, length) : avr::g_uart2.write(src, length);
  SREG = sreg;
  return n;
}

uint16_t serial_tx_free(Port port) {
  return port == kUart0 ? avr::g_uart0.tx.free_space() : avr::g_uart2.tx.free_space();
}

}  // namespace hal
}  // namespace quad

ISR(USART0_RX_vect) { quad::hal::avr::g_uart0.on_receive(); }
ISR(USART0_UDRE_vect) { quad::hal::avr::g_uart0.on_data_register_empty(); }
ISR(USART2_RX_vect) { quad::hal::avr::g_uart2.on_receive(); }
ISR(USART2_UDRE_vect) { quad::hal::avr::g_uart2.on_data_register_empty(); }
