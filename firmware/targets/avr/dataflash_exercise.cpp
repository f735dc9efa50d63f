// The DataFlash log store driven over UART0 (1 Mbaud) for tests/pil/test_apm25_dataflash.cpp: each
// command byte with its arguments (little-endian) gets one answer, so the test decides what is written
// and checks what is read back against its own copy.
//   after boot                    'B' started(u8)                  dataflash_start()
//   'O' time(u32)                 'o' ok(u8)                       open
//   'W' n(u8) data[n]             'w' taken(u8) us(u16)            append, with its duration in us
//   'C'                           'c'                              close
//   'N'                           'n' count(u16)
//   'E' id(u16)                   'e' ok(u8) size(u32) time(u32)   entry
//   'R' id(u16) ofs(u32) n(u8)    'r' got(u8) data[got]            read
//   'X'                           'x' ok(u8)                       erase_all
#include "quad/hal/dataflash.h"
#include "quad/hal/hal.h"

namespace {

namespace avr = quad::hal::avr;
using quad::hal::kUart0;

uint8_t next_byte() {
  uint8_t b;
  while (quad::hal::serial_read(kUart0, &b, 1) == 0) {
  }
  return b;
}
uint32_t next_u(uint8_t bytes) {
  uint32_t v = 0;
  for (uint8_t i = 0; i < bytes; ++i) v |= static_cast<uint32_t>(next_byte()) << (8 * i);
  return v;
}
uint8_t* put(uint8_t* p, uint32_t v, uint8_t bytes) {
  for (uint8_t i = 0; i < bytes; ++i) *p++ = static_cast<uint8_t>(v >> (8 * i));
  return p;
}
void send(const uint8_t* data, uint16_t n) {
  uint16_t sent = 0;
  while (sent < n) sent = static_cast<uint16_t>(sent + quad::hal::serial_write(kUart0, data + sent, n - sent));
}

}  // namespace

int main() {
  quad::hal::init();
  uint8_t out[2 + 255];
  out[0] = 'B';
  out[1] = avr::dataflash_start() ? 1 : 0;
  send(out, 2);
  for (;;) {
    const uint8_t op = next_byte();
    uint8_t* p = out + 1;
    out[0] = static_cast<uint8_t>(op + ('a' - 'A'));
    if (op == 'O') {
      *p++ = avr::dataflash_open(nullptr, next_u(4)) ? 1 : 0;
    } else if (op == 'W') {
      uint8_t data[255];
      const uint8_t n = next_byte();
      for (uint8_t i = 0; i < n; ++i) data[i] = next_byte();
      const uint32_t t0 = quad::hal::micros();
      const uint16_t taken = avr::dataflash_append(nullptr, data, n);
      p = put(put(p, taken, 1), quad::hal::micros() - t0, 2);
    } else if (op == 'C') {
      avr::dataflash_close(nullptr);
    } else if (op == 'N') {
      p = put(p, avr::dataflash_count(nullptr), 2);
    } else if (op == 'E') {
      uint32_t size = 0, time = 0;
      const bool ok = avr::dataflash_entry(nullptr, static_cast<uint16_t>(next_u(2)), &size, &time);
      p = put(put(put(p, ok ? 1 : 0, 1), size, 4), time, 4);
    } else if (op == 'R') {
      const uint16_t id = static_cast<uint16_t>(next_u(2));
      const uint32_t ofs = next_u(4);
      const uint8_t n = next_byte();
      const uint16_t got = avr::dataflash_read(nullptr, id, ofs, p + 1, n);
      *p = static_cast<uint8_t>(got);
      p += 1 + got;
    } else if (op == 'X') {
      *p++ = avr::dataflash_erase_all(nullptr) ? 1 : 0;
    } else {
      out[0] = '?';
    }
    send(out, static_cast<uint16_t>(p - out));
  }
}
