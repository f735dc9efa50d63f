// AT45DB321D DataFlash on USART3 in SPI master mode (MSPIM, SPI mode 0, 8 MHz), chip select PA6 and
// RESET PG0, as ArduPilot's APM2 HAL wires it. Layout (528-byte pages, docs/logging.md):
//   pages 0, 1      two copies of the index, written in turn: magic, erase generation, the next log's
//                   serial, 64 slots (slot = serial mod 64: serial, first page, time), an update count and
//                   a check word; at boot the valid copy with the higher update count is the index
//   pages 2..8191   the ring of log data: 512 bytes per page and a trailer (check word, generation, the
//                   log's serial, the page's sequence in the log, the bytes it holds)
// Logs follow each other around the ring. When the page a log is about to program is the first page of
// the oldest log, that log is dropped (its slot stays in the index, its first page no longer names it);
// when the page after the one programmed is the writing log's own first page, the chip holds nothing but
// that log and it ends there.
// A log's size is not stored: the trailers give it (the last page's sequence and byte count), so a log
// that was open at a reset keeps what reached the flash, and close() needs no index write.
#include "quad/hal/dataflash.h"

#include <avr/io.h>

#include "board.h"

namespace quad {
namespace hal {
namespace avr {
namespace {

#ifndef QUAD_DATAFLASH_PAGES
#define QUAD_DATAFLASH_PAGES 8192  // the AT45DB321D; the ring's test builds the driver for a smaller part
#endif
constexpr uint16_t kPages = QUAD_DATAFLASH_PAGES;
constexpr uint16_t kFirstDataPage = 2;  // pages 0 and 1 hold the index
constexpr uint16_t kRingPages = kPages - kFirstDataPage;
constexpr uint16_t kDataBytes = 512;  // per page; the trailer follows
constexpr uint16_t kTrailerOffset = 512;
constexpr uint16_t kSlots = 64;  // a power of two: a serial's slot is serial & (kSlots - 1)
constexpr uint16_t kSlotOffset = 8, kSlotLength = 8;
constexpr uint16_t kNextOffset = 6, kUpdateOffset = kSlotOffset + kSlots * kSlotLength;  // 520
constexpr uint8_t kMagic[4] = {'Q', 'L', 'G', '2'};
constexpr uint16_t kTrailerSeed = 0x5144, kIndexSeed = 0x5149;
constexpr uint16_t kEmptySlotsSum = static_cast<uint16_t>(kSlots * 4u * 0xFFFFu);  // 256 words of 0xFFFF
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

// Blocks of a command's data, with SCK never idle between bytes (fosc/2: 16 cycles a byte). MSPIM's
// transmit buffer is double: the next byte goes into UDR3 while the one before it shifts out, and that
// one's answer is read behind it, so the receive FIFO (two bytes) never overflows. Measured on simavr
// (test_apm25_dataflash): 27 cycles a byte, against 46 a byte through xfer() (a call, and the wait for
// each answer before the next byte goes).
void send_block(const uint8_t* src, uint16_t n) {
  if (n == 0) return;
  UDR3 = *src++;
  while (--n != 0) {
    const uint8_t next = *src++;
    while (!(UCSR3A & _BV(UDRE3))) {
    }
    UDR3 = next;
    while (!(UCSR3A & _BV(RXC3))) {
    }
    (void)UDR3;
  }
  while (!(UCSR3A & _BV(RXC3))) {
  }
  (void)UDR3;
}
void receive_block(uint8_t* dst, uint16_t n) {
  if (n == 0) return;
  UDR3 = 0;
  while (--n != 0) {
    while (!(UCSR3A & _BV(UDRE3))) {
    }
    UDR3 = 0;
    while (!(UCSR3A & _BV(RXC3))) {
    }
    *dst++ = UDR3;
  }
  while (!(UCSR3A & _BV(RXC3))) {
  }
  *dst = UDR3;
}
void select() { PORTA &= static_cast<uint8_t>(~kCs); }
void deselect() { PORTA |= kCs; }

// Opcode and the 24-bit address of 528-byte page mode: page in bits 22..10, byte in bits 9..0.
void command(uint8_t op, uint16_t page, uint16_t byte) {
  const uint8_t bytes[4] = {op, static_cast<uint8_t>(page >> 6), static_cast<uint8_t>((page << 2) | (byte >> 8)),
                            static_cast<uint8_t>(byte)};
  select();
  send_block(bytes, sizeof bytes);
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

void put16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
void write_buffer(uint8_t buffer, uint16_t byte, const uint8_t* src, uint8_t n) {
  command(kBufferWrite[buffer], 0, byte);
  send_block(src, n);
  deselect();
}

uint16_t next_page(uint16_t p) { return p + 1u == kPages ? kFirstDataPage : static_cast<uint16_t>(p + 1u); }
uint16_t previous_page(uint16_t p) { return p == kFirstDataPage ? kPages - 1u : static_cast<uint16_t>(p - 1u); }
// The page `pages` after `start` around the ring (pages < kRingPages).
uint16_t ring_page(uint16_t start, uint16_t pages) {
  const uint16_t p = static_cast<uint16_t>(start + pages);
  return p >= kPages ? static_cast<uint16_t>(p - kRingPages) : p;
}
uint16_t slot_offset(uint16_t serial) { return kSlotOffset + (serial & (kSlots - 1u)) * kSlotLength; }

struct Trailer {
  uint16_t check, generation, serial, sequence, used;
};
uint16_t trailer_check(uint16_t generation, uint16_t serial, uint16_t sequence, uint16_t used) {
  return static_cast<uint16_t>(kTrailerSeed + generation + serial + sequence + used);
}

Trailer read_trailer(uint16_t page) {
  page_read(page, kTrailerOffset);
  Trailer t;
  t.check = read16();
  t.generation = read16();
  t.serial = read16();
  t.sequence = read16();
  t.used = read16();
  deselect();
  return t;
}

struct Store {
  bool present = false;
  bool open = false;
  bool full = false;            // the open log holds the whole ring: it takes nothing more
  bool flush_pending = false;   // the closed log's last page waits in the current buffer
  bool lookup_pending = false;  // the oldest log's first page is to be read from the index
  uint8_t index_step = 0;  // open()'s slot: 1 the replaced slot's words, 2 the index to the spare buffer, 3 the
                           // next serial, update count and check into it, 4 the slot, and the program
  uint8_t buffer = 0;      // the buffer being filled
  uint8_t index_page = 0;  // the index copy that is valid
  uint16_t generation = 0;
  uint16_t index_next = 0, index_update = 0, index_check = 0;  // that copy's fields
  uint16_t replaced_sum = 0;  // the words of the slot the pending index update replaces
  uint16_t next_serial = 0;   // the newest log is next_serial - 1
  uint16_t oldest_serial = 0;  // logs held: next_serial - oldest_serial
  uint16_t oldest_start = kNoPage;       // the oldest log's first page: where the writer drops it
  uint16_t last_start = kFirstDataPage;  // the open log's first page
  uint16_t page = kFirstDataPage;        // the page the current buffer goes to
  uint16_t fill = 0;                     // bytes in the current buffer
  uint32_t last_size = 0;                // the open log's bytes
  uint32_t open_time = 0;
  bool cached = false;  // a closed log's place, while it is read out
  uint16_t cached_serial = 0;
  uint16_t cached_start = 0;
  uint32_t cached_size = 0;
  uint32_t cached_time = 0;
};
Store g;

uint16_t held() { return static_cast<uint16_t>(g.next_serial - g.oldest_serial); }
uint16_t open_serial() { return static_cast<uint16_t>(g.next_serial - 1u); }

// Whether a trailer is page `sequence` of log `serial` of this generation (a torn one fails its check).
bool names(const Trailer& t, uint16_t serial, uint16_t sequence) {
  return t.check == trailer_check(t.generation, t.serial, t.sequence, t.used) && t.generation == g.generation &&
         t.serial == serial && t.sequence == sequence && t.used <= kDataBytes;
}

// The slot of `serial` in the valid index copy: false unless it holds that log with a data page.
bool read_slot(uint16_t serial, uint16_t* start, uint32_t* time_utc) {
  page_read(g.index_page, slot_offset(serial));
  const uint16_t held_serial = read16();
  *start = read16();
  *time_utc = read32();
  deselect();
  return held_serial == serial && *start >= kFirstDataPage && *start < kPages;
}

// The oldest log goes: its pages are the writer's from here on. The next one's first page comes from
// RAM for the open log, else from the index (read by service(), before the next page is programmed).
void drop_oldest() {
  ++g.oldest_serial;
  if (g.oldest_serial == g.next_serial) {
    g.oldest_start = kNoPage;
  } else if (g.open && g.oldest_serial == open_serial()) {
    g.oldest_start = g.last_start;
  } else {
    g.lookup_pending = true;
  }
}

void read_oldest_start() {
  uint16_t start;
  uint32_t time_utc;
  g.lookup_pending = false;
  if (read_slot(g.oldest_serial, &start, &time_utc)) {
    g.oldest_start = start;
  } else {  // a damaged index: keep only the open log, whose place is known
    g.oldest_serial = g.open ? open_serial() : g.next_serial;
    g.oldest_start = g.open ? g.last_start : kNoPage;
  }
}

// The current buffer, its trailer added, into its page; the next page is filled from the other buffer.
// The chip must be ready and the oldest log's first page known. An older log whose first page this is
// goes now, when its first page is overwritten; when the next page is the open log's own first page,
// the ring holds nothing else and the log ends (as ArduPilot's block logger stops at "chip full").
void program_current() {
  if (g.page == g.oldest_start && g.oldest_serial != open_serial()) drop_oldest();
  const uint16_t serial = open_serial();
  const uint16_t sequence = g.page >= g.last_start ? static_cast<uint16_t>(g.page - g.last_start)
                                                   : static_cast<uint16_t>(g.page + kRingPages - g.last_start);
  uint8_t t[10];
  put16(t, trailer_check(g.generation, serial, sequence, g.fill));
  put16(t + 2, g.generation);
  put16(t + 4, serial);
  put16(t + 6, sequence);
  put16(t + 8, g.fill);
  write_buffer(g.buffer, kTrailerOffset, t, sizeof t);
  command(kProgram[g.buffer], g.page, 0);
  deselect();
  g.page = next_page(g.page);
  g.buffer ^= 1u;
  g.fill = 0;
  g.full = g.page == g.last_start;
}

// The next serial, the update count and the check into the spare buffer (which holds the valid copy);
// the check follows from the words the update replaces.
void write_index_header() {
  const uint8_t spare = g.buffer ^ 1u;
  const uint16_t update = static_cast<uint16_t>(g.index_update + 1u);
  const uint16_t check = static_cast<uint16_t>(g.index_check - g.index_next + g.next_serial - g.replaced_sum +
                                               open_serial() + g.last_start + static_cast<uint16_t>(g.open_time) +
                                               static_cast<uint16_t>(g.open_time >> 16) - g.index_update + update);
  uint8_t bytes[4];
  put16(bytes, g.next_serial);
  write_buffer(spare, kNextOffset, bytes, 2);
  put16(bytes, update);
  put16(bytes + 2, check);
  write_buffer(spare, kUpdateOffset, bytes, 4);
  g.index_next = g.next_serial;
  g.index_update = update;
  g.index_check = check;
}
// The open log's slot into the spare buffer, programmed into the other copy.
void write_index_slot() {
  const uint8_t spare = g.buffer ^ 1u;
  const uint16_t serial = open_serial();
  uint8_t bytes[8];
  put16(bytes, serial);
  put16(bytes + 2, g.last_start);
  put16(bytes + 4, static_cast<uint16_t>(g.open_time));
  put16(bytes + 6, static_cast<uint16_t>(g.open_time >> 16));
  write_buffer(spare, slot_offset(serial), bytes, 8);
  g.index_page ^= 1u;
  command(kProgram[spare], g.index_page, 0);
  deselect();
}

// Work left by open(), close() and a dropped log, one chip operation per call while the chip is ready;
// true when it sent one.
bool serve_pending() {
  if (!ready()) return false;
  if (g.lookup_pending) {
    read_oldest_start();
  } else if (g.index_step == 1) {
    page_read(g.index_page, slot_offset(open_serial()));
    g.replaced_sum = static_cast<uint16_t>(read16() + read16() + read16() + read16());
    deselect();
    g.index_step = 2;
  } else if (g.index_step == 2) {
    command(kTransfer[g.buffer ^ 1u], g.index_page, 0);
    deselect();
    g.index_step = 3;
  } else if (g.index_step == 3) {
    write_index_header();
    g.index_step = 4;
  } else if (g.index_step == 4) {
    write_index_slot();
    g.index_step = 0;
  } else {
    program_current();
    g.flush_pending = false;
  }
  return true;
}
// Called by every function: inline, so that an append with nothing pending pays three tests, not a call.
__attribute__((always_inline)) inline bool service() {
  return (g.index_step != 0 || g.flush_pending || g.lookup_pending) && serve_pending();
}

void finish_pending() {
  while (g.index_step != 0 || g.flush_pending || g.lookup_pending) service();
  wait_ready();
}

// An index without logs, of generation g.generation, into `copy` from buffer 0 (the chip must be ready).
void write_empty_index(uint8_t copy) {
  const uint16_t update = static_cast<uint16_t>(g.index_update + 1u);
  const uint16_t check = static_cast<uint16_t>(kIndexSeed + g.generation + g.next_serial + kEmptySlotsSum + update);
  command(kBufferWrite[0], 0, 0);
  for (uint8_t b : kMagic) xfer(b);
  write16(g.generation);
  write16(g.next_serial);
  for (uint16_t i = kSlotOffset; i < kUpdateOffset; ++i) xfer(0xFF);
  write16(update);
  write16(check);
  for (uint16_t i = kUpdateOffset + 4; i < 528; ++i) xfer(0xFF);
  deselect();
  command(kProgram[0], copy, 0);
  deselect();
  g.buffer = 1;
  g.index_page = copy;
  g.index_next = g.next_serial;
  g.index_update = update;
  g.index_check = check;
}

// One index copy, its check summed over the words as they are read; false when it is not a whole index.
bool read_index_copy(uint8_t copy, uint16_t* generation, uint16_t* next, uint16_t* update, uint16_t* check) {
  page_read(copy, 0);
  bool magic = true;
  for (uint8_t b : kMagic) magic = xfer(0) == b && magic;
  *generation = read16();
  *next = read16();
  uint16_t sum = static_cast<uint16_t>(kIndexSeed + *generation + *next);
  for (uint16_t i = 0; i < kSlots * 4u; ++i) sum = static_cast<uint16_t>(sum + read16());
  *update = read16();
  *check = read16();
  deselect();
  return magic && *check == static_cast<uint16_t>(sum + *update);
}

// The valid copy with the higher update count (a copy torn by a reset during its program fails its check).
bool read_index() {
  bool found = false;
  for (uint8_t copy = 0; copy < 2; ++copy) {
    uint16_t generation, next, update, check;
    if (!read_index_copy(copy, &generation, &next, &update, &check)) continue;
    if (found && static_cast<int16_t>(update - g.index_update) <= 0) continue;
    found = true;
    g.index_page = copy;
    g.generation = generation;
    g.next_serial = g.index_next = next;
    g.index_update = update;
    g.index_check = check;
  }
  return found;
}

bool intact(uint16_t serial, uint16_t* start) {
  uint32_t time_utc;
  return read_slot(serial, start, &time_utc) && names(read_trailer(*start), serial, 0);
}

// The logs the flash holds: the newest whose first page names it (a log opened just before a reset may
// have none; its serial is taken again), its end where its trailers stop naming it in sequence, and the
// older ones back to the first whose first page the writer took (dropped) or whose slot was reused.
void find_logs() {
  uint16_t start = kFirstDataPage;
  uint16_t back = 1;
  while (back <= kSlots && !intact(static_cast<uint16_t>(g.next_serial - back), &start)) ++back;
  if (back > kSlots) {
    g.oldest_serial = g.next_serial;
    return;
  }
  g.next_serial = static_cast<uint16_t>(g.next_serial - back + 1u);
  const uint16_t newest = open_serial();
  uint16_t pages = 0;
  g.page = start;
  while (pages < kRingPages && names(read_trailer(g.page), newest, pages)) {
    ++pages;
    g.page = next_page(g.page);
  }
  g.oldest_serial = newest;
  g.oldest_start = start;
  for (uint16_t older = 1; older < kSlots; ++older) {
    const uint16_t serial = static_cast<uint16_t>(newest - older);
    if (!intact(serial, &start)) break;
    g.oldest_serial = serial;
    g.oldest_start = start;
  }
}

// Where log id (1..count, oldest first) lies: the open log from RAM, a closed one from its slot and its
// last page's trailer (the page before the next log's first page, or before the writer's page); false
// while a page is being programmed (main memory cannot be read then).
bool locate(uint16_t id, uint16_t* start, uint32_t* size, uint32_t* time) {
  if (!g.present || id == 0 || id > held()) return false;
  const uint16_t serial = static_cast<uint16_t>(g.oldest_serial + id - 1u);
  if (g.open && serial == open_serial()) {
    *start = g.last_start;
    *size = g.last_size;
    *time = g.open_time;
    return true;
  }
  if (!g.cached || serial != g.cached_serial) {
    if (!ready()) return false;
    uint16_t first, next = g.page;
    uint32_t time_utc, unused;
    const bool found = read_slot(serial, &first, &time_utc);
    if (g.open && static_cast<uint16_t>(serial + 1u) == open_serial()) {
      next = g.last_start;
    } else if (static_cast<uint16_t>(serial + 1u) != g.next_serial) {
      read_slot(static_cast<uint16_t>(serial + 1u), &next, &unused);
    }
    const Trailer t = read_trailer(previous_page(next));
    uint32_t bytes = 0;
    if (found && t.check == trailer_check(t.generation, t.serial, t.sequence, t.used) &&
        t.generation == g.generation && t.serial == serial && t.used <= kDataBytes) {
      bytes = static_cast<uint32_t>(t.sequence) * kDataBytes + t.used;
    }
    g.cached = true;
    g.cached_serial = serial;
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
  g.present = true;
  if (read_index()) {
    find_logs();
  } else {
    write_empty_index(0);  // a fresh chip: generation 0
    wait_ready();
  }
  return true;
}

bool dataflash_open(void* context, uint32_t time_utc_s) {
  if (!g.present) return false;
  if (g.open) dataflash_close(context);
  finish_pending();
  // The new log's slot: the log holding it is dropped (at most 64 logs). A log whose first page the new
  // one starts on goes with the first page programmed.
  if (held() >= kSlots) drop_oldest();
  finish_pending();
  if (held() == 0) g.oldest_start = g.page;
  ++g.next_serial;
  g.last_start = g.page;
  g.last_size = 0;
  g.fill = 0;
  g.open_time = time_utc_s;
  g.open = true;
  g.full = false;
  g.index_step = 1;
  service();
  return true;
}

uint16_t dataflash_append(void*, const uint8_t* data, uint16_t length) {
  if (!g.open) return 0;
  const bool serviced = service();
  uint16_t taken = 0;
  while (taken < length && !g.full) {
    if (g.fill == kDataBytes) {
      // Both buffers in use (the other one's page still programming, or the index), the oldest log's
      // first page not read yet, or a chip operation done in this call already: the rest waits.
      if (serviced || g.index_step != 0 || g.lookup_pending || !ready()) break;
      program_current();
      continue;
    }
    uint16_t n = static_cast<uint16_t>(kDataBytes - g.fill);
    if (n > length - taken) n = static_cast<uint16_t>(length - taken);
    command(kBufferWrite[g.buffer], 0, g.fill);
    send_block(data + taken, n);
    deselect();
    g.fill = static_cast<uint16_t>(g.fill + n);
    g.last_size += n;
    taken = static_cast<uint16_t>(taken + n);
  }
  return taken;
}

void dataflash_close(void*) {
  if (!g.open) return;
  // The last page now (an empty log gets one with no bytes), so the log is whole in the flash without
  // another call: once per log, at most the page being programmed is waited for.
  g.flush_pending = !g.full && (g.fill > 0 || g.last_size == 0);
  finish_pending();
  g.open = false;
}

uint16_t dataflash_count(void*) {
  service();
  return held();
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
  const uint16_t page = ring_page(start, static_cast<uint16_t>(offset >> 9));
  const uint16_t byte = static_cast<uint16_t>(offset & (kDataBytes - 1u));
  uint16_t n = static_cast<uint16_t>(kDataBytes - byte);  // to the end of the page
  if (n > length) n = length;
  if (n > size - offset) n = static_cast<uint16_t>(size - offset);
  if (g.open && id == held() && offset >= g.last_size - g.fill) {
    // The open log's last bytes are still in the buffer being filled (readable while busy).
    command(kBufferRead[g.buffer], 0, byte);
    xfer(0);
  } else {
    if (!ready()) return 0;
    page_read(page, byte);
  }
  receive_block(dst, n);
  deselect();
  return n;
}

bool dataflash_erase_all(void*) {
  if (!g.present || g.open) return false;
  finish_pending();
  ++g.generation;  // the old pages' trailers no longer match any log
  write_empty_index(g.index_page ^ 1u);
  g.oldest_serial = g.next_serial;
  g.oldest_start = kNoPage;
  g.page = kFirstDataPage;
  g.fill = 0;
  g.full = false;
  g.cached = false;
  return true;
}

}  // namespace avr
}  // namespace hal
}  // namespace quad
