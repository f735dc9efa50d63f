// AT45DB321D DataFlash on USART3 in SPI master mode (MSPIM, SPI mode 0, 8 MHz), chip select PA6 and
// RESET PG0, as ArduPilot's APM2 HAL wires it. Layout (528-byte pages, docs/logging.md):
//   page 0          the index: magic, erase generation, then one 8-byte slot per log (start page, time)
//   pages 1..8191   log data: 512 bytes per page and a trailer in the page's last 16 bytes (generation,
//                   the log's start page, the page's sequence in the log, the bytes it holds)
// A log's size is not stored: the trailers give it (the last page's sequence and byte count), so a log
// that was open at a reset keeps what reached the flash, and close() needs no index write.
#include "quad/hal/dataflash.h"

#include <avr/io.h>

#include "board.h"

namespace quad {
namespace hal {
namespace avr {
namespace {

constexpr uint16_t kPages = 8192, kIndexPage = 0, kFirstDataPage = 1;
constexpr uint16_t kDataBytes = 512;          // per page; the trailer follows
constexpr uint16_t kTrailerOffset = 512;
constexpr uint8_t kTrailerLength = 10;
constexpr uint16_t kMaxLogs = 64;
constexpr uint8_t kIndexHeader = 8, kSlotLength = 8;
constexpr uint8_t kMagic[4] = {'Q', 'L', 'G', '1'};
constexpr uint16_t kTrailerMagic = 0x5144;
constexpr uint16_t kNoPage = 0xFFFF;

// Opcodes (AT45DB321D datasheet), per buffer where there are two.
constexpr uint8_t kStatusRead = 0xD7, kIdRead = 0x9F, kPageRead = 0xD2;
constexpr uint8_t kBufferWrite[2] = {0x84, 0x87}, kBufferRead[2] = {0xD4, 0xD6};
constexpr uint8_t kProgram[2] = {0x83, 0x86}, kTransfer[2] = {0x53, 0x55};
constexpr uint8_t kReady = 0x80, kPageSize512 = 0x01;

constexpr uint8_t kCs = _BV(PA6), kReset = _BV(PG0);

uint8_t xfer(uint8_t out) {
  UDR3 = out;
  while (!(UCSR3A & _BV(RXC3))) {
  }
  return UDR3;
}
void select() { PORTA &= static_cast<uint8_t>(~kCs); }
void deselect() { PORTA |= kCs; }

// Opcode and the 24-bit address of 528-byte page mode: page in bits 22..10, byte in bits 9..0.
void command(uint8_t op, uint16_t page, uint16_t byte) {
  select();
  xfer(op);
  xfer(static_cast<uint8_t>(page >> 6));
  xfer(static_cast<uint8_t>((page << 2) | (byte >> 8)));
  xfer(static_cast<uint8_t>(byte));
}
// A main memory page read from `byte`: the command, then four don't-care bytes; CS stays low.
void page_read(uint16_t page, uint16_t byte) {
  command(kPageRead, page, byte);
  for (uint8_t i = 0; i < 4; ++i) xfer(0);
}
uint16_t read16() {
  const uint8_t lo = xfer(0);
  return static_cast<uint16_t>(lo | (xfer(0) << 8));
}
uint32_t read32() {
  const uint16_t lo = read16();
  return lo | (static_cast<uint32_t>(read16()) << 16);
}
void write16(uint16_t v) {
  xfer(static_cast<uint8_t>(v));
  xfer(static_cast<uint8_t>(v >> 8));
}

uint8_t status() {
  select();
  xfer(kStatusRead);
  const uint8_t s = xfer(0);
  deselect();
  return s;
}
bool ready() { return (status() & kReady) != 0; }
void wait_ready() {
  while (!ready()) {
  }
}

struct Trailer {
  uint16_t magic, generation, start, sequence, used;
};

Trailer read_trailer(uint16_t page) {
  page_read(page, kTrailerOffset);
  Trailer t;
  t.magic = read16();
  t.generation = read16();
  t.start = read16();
  t.sequence = read16();
  t.used = read16();
  deselect();
  return t;
}

struct Store {
  bool present = false;
  bool open = false;
  bool flush_pending = false;  // the closed log's last page waits in the current buffer
  uint8_t index_step = 0;      // an open()'s index slot: 1 page 0 to the spare buffer, 2 slot and program
  uint8_t buffer = 0;          // the buffer being filled
  uint16_t generation = 0;
  uint16_t count = 0;
  uint16_t last_start = kFirstDataPage;  // the newest log's first page
  uint16_t page = kFirstDataPage;        // the page the current buffer goes to (kPages: full)
  uint16_t fill = 0;                     // bytes in the current buffer
  uint32_t last_size = 0;                // the newest log's bytes
  uint32_t open_time = 0;                // for the pending index slot
  uint16_t cached_id = 0;                // an older log's place, while it is read out
  uint16_t cached_start = 0;
  uint32_t cached_size = 0;
  uint32_t cached_time = 0;
};
Store g;

// The current buffer, its trailer added, into its page; the next page is filled from the other buffer.
// The chip must be ready.
void program_current() {
  command(kBufferWrite[g.buffer], 0, kTrailerOffset);
  write16(kTrailerMagic);
  write16(g.generation);
  write16(g.last_start);
  write16(static_cast<uint16_t>(g.page - g.last_start));
  write16(g.fill);
  deselect();
  command(kProgram[g.buffer], g.page, 0);
  deselect();
  ++g.page;
  g.buffer ^= 1u;
  g.fill = 0;
}

// Work left by open() and close(), one chip operation per call while the chip is ready.
void service() {
  if (g.index_step == 0 && !g.flush_pending) return;
  if (!ready()) return;
  const uint8_t spare = g.buffer ^ 1u;
  if (g.index_step == 1) {
    command(kTransfer[spare], kIndexPage, 0);
    deselect();
    g.index_step = 2;
  } else if (g.index_step == 2) {
    command(kBufferWrite[spare], 0, kIndexHeader + (g.count - 1u) * kSlotLength);
    write16(g.last_start);
    write16(0xFFFF);
    write16(static_cast<uint16_t>(g.open_time));
    write16(static_cast<uint16_t>(g.open_time >> 16));
    deselect();
    command(kProgram[spare], kIndexPage, 0);
    deselect();
    g.index_step = 0;
  } else {
    program_current();
    g.flush_pending = false;
  }
}

void finish_pending() {
  while (g.index_step != 0 || g.flush_pending) service();
  wait_ready();
}

// Writes an empty index of generation g.generation from buffer 0 (the chip must be ready).
void write_empty_index() {
  command(kBufferWrite[0], 0, 0);
  for (uint8_t b : kMagic) xfer(b);
  write16(g.generation);
  for (uint16_t i = 4 + 2; i < 528; ++i) xfer(0xFF);
  deselect();
  command(kProgram[0], kIndexPage, 0);
  deselect();
  g.buffer = 1;
}

// The newest log's end: its pages are the run from its start page whose trailers name it in order.
void find_end_of_newest() {
  g.page = g.last_start;
  g.last_size = 0;
  for (uint16_t p = g.last_start; p < kPages; ++p) {
    const Trailer t = read_trailer(p);
    if (t.magic != kTrailerMagic || t.generation != g.generation || t.start != g.last_start ||
        t.sequence != p - g.last_start || t.used > kDataBytes) {
      break;
    }
    g.last_size = static_cast<uint32_t>(t.sequence) * kDataBytes + t.used;
    g.page = static_cast<uint16_t>(p + 1);
  }
}

// Where log id (1..count) lies: the newest from RAM, an older one from the index and its last page's
// trailer; false while a page is being programmed (main memory cannot be read then).
bool locate(uint16_t id, uint16_t* start, uint32_t* size, uint32_t* time) {
  if (!g.present || id == 0 || id > g.count) return false;
  if (id == g.count) {
    *start = g.last_start;
    *size = g.last_size;
    *time = g.open_time;
    return true;
  }
  if (id != g.cached_id) {
    if (!ready()) return false;
    page_read(kIndexPage, kIndexHeader + (id - 1u) * kSlotLength);
    const uint16_t first = read16();
    read16();
    const uint32_t time_utc = read32();
    const uint16_t next_in_index = read16();
    deselect();
    // This log ends before the next one's start (the newest's slot may still be on its way to the index).
    const uint16_t next = id + 1u == g.count ? g.last_start : next_in_index;
    uint32_t bytes = 0;
    if (next > first) {
      const Trailer t = read_trailer(static_cast<uint16_t>(next - 1u));
      if (t.magic == kTrailerMagic && t.generation == g.generation && t.start == first && t.used <= kDataBytes) {
        bytes = static_cast<uint32_t>(t.sequence) * kDataBytes + t.used;
      }
    }
    g.cached_id = id;
    g.cached_start = first;
    g.cached_size = bytes;
    g.cached_time = time_utc;
  }
  *start = g.cached_start;
  *size = g.cached_size;
  *time = g.cached_time;
  return true;
}

}  // namespace

bool dataflash_start() {
  g = Store();
  PORTG &= static_cast<uint8_t>(~kReset);  // a reset pulse (at least 10 us) ends any half-sent command
  DDRG |= kReset;
  PORTA |= kCs;
  DDRA |= kCs;
  DDRJ |= _BV(PJ2) | _BV(PJ1);  // XCK3 (SCK) and TXD3 (MOSI) out
  wait_us(20);
  PORTG |= kReset;
  wait_us(2);
  // MSPIM, mode 0, MSB first; the baud register last (datasheet: after the transmitter is enabled).
  UBRR3 = 0;
  UCSR3C = _BV(UMSEL31) | _BV(UMSEL30);
  UCSR3B = _BV(RXEN3) | _BV(TXEN3);
  UBRR3 = 0;  // F_CPU / 2: 8 MHz
  select();
  xfer(kIdRead);
  const uint8_t manufacturer = xfer(0);
  const uint8_t device = xfer(0);
  deselect();
  if (manufacturer != 0x1F || (device & 0x1F) != 0x07) return false;  // Atmel, 32 Mbit
  wait_ready();
  if (status() & kPageSize512) return false;  // the trailers need 528-byte pages
  page_read(kIndexPage, 0);
  bool formatted = true;
  for (uint8_t b : kMagic) formatted = formatted && xfer(0) == b;
  g.generation = read16();
  deselect();
  g.present = true;
  if (!formatted) {
    g.generation = 0;
    write_empty_index();
    wait_ready();
    return true;
  }
  page_read(kIndexPage, kIndexHeader);
  for (uint16_t slot = 0; slot < kMaxLogs; ++slot) {
    const uint16_t start = read16();
    read16();
    const uint32_t time_utc = read32();
    if (start == kNoPage) break;
    g.count = static_cast<uint16_t>(slot + 1);
    g.last_start = start;
    g.open_time = time_utc;
  }
  deselect();
  if (g.count > 0) find_end_of_newest();
  return true;
}

bool dataflash_open(void* context, uint32_t time_utc_s) {
  if (!g.present) return false;
  if (g.open) dataflash_close(context);
  finish_pending();
  if (g.count >= kMaxLogs || g.page >= kPages) return false;
  ++g.count;
  g.last_start = g.page;
  g.last_size = 0;
  g.fill = 0;
  g.open_time = time_utc_s;
  g.open = true;
  g.index_step = 1;
  g.cached_id = 0;
  service();
  return true;
}

uint16_t dataflash_append(void*, const uint8_t* data, uint16_t length) {
  if (!g.open) return 0;
  service();
  uint16_t taken = 0;
  while (taken < length && g.page < kPages) {
    if (g.fill == kDataBytes) {
      // Both buffers in use (the other one's page still programming, or the index): the rest waits.
      if (g.index_step != 0 || !ready()) break;
      program_current();
      continue;
    }
    uint16_t n = static_cast<uint16_t>(kDataBytes - g.fill);
    if (n > length - taken) n = static_cast<uint16_t>(length - taken);
    command(kBufferWrite[g.buffer], 0, g.fill);
    for (uint16_t i = 0; i < n; ++i) xfer(data[taken + i]);
    deselect();
    g.fill = static_cast<uint16_t>(g.fill + n);
    g.last_size += n;
    taken = static_cast<uint16_t>(taken + n);
  }
  return taken;
}

void dataflash_close(void*) {
  if (!g.open) return;
  g.open = false;
  g.flush_pending = g.fill > 0 && g.page < kPages;
  // The last page now, so the log is whole in the flash without another call: once per log, at most
  // the page being programmed is waited for.
  finish_pending();
}

uint16_t dataflash_count(void*) {
  service();
  return g.count;
}

bool dataflash_entry(void*, uint16_t id, uint32_t* size_bytes, uint32_t* time_utc_s) {
  service();
  uint16_t start;
  return locate(id, &start, size_bytes, time_utc_s);
}

uint16_t dataflash_read(void*, uint16_t id, uint32_t offset, uint8_t* dst, uint16_t length) {
  service();
  uint16_t start;
  uint32_t size, time_utc;
  if (!locate(id, &start, &size, &time_utc) || offset >= size) return 0;
  const uint16_t page = static_cast<uint16_t>(start + (offset >> 9));
  const uint16_t byte = static_cast<uint16_t>(offset & (kDataBytes - 1u));
  uint16_t n = static_cast<uint16_t>(kDataBytes - byte);  // to the end of the page
  if (n > length) n = length;
  if (n > size - offset) n = static_cast<uint16_t>(size - offset);
  if (id == g.count && page == g.page) {
    // The newest log's last bytes are still in the buffer being filled (readable while busy).
    command(kBufferRead[g.buffer], 0, byte);
    xfer(0);
  } else {
    if (!ready()) return 0;
    page_read(page, byte);
  }
  for (uint16_t i = 0; i < n; ++i) dst[i] = xfer(0);
  deselect();
  return n;
}

bool dataflash_erase_all(void*) {
  if (!g.present || g.open) return false;
  finish_pending();
  ++g.generation;  // the old pages' trailers no longer match any log
  write_empty_index();
  g.count = 0;
  g.last_start = kFirstDataPage;
  g.page = kFirstDataPage;
  g.fill = 0;
  g.last_size = 0;
  g.cached_id = 0;
  return true;
}

}  // namespace avr
}  // namespace hal
}  // namespace quad
