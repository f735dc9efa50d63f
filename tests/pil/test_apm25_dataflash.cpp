// The APM 2.5's DataFlash log store (hal/avr/dataflash.cpp) on simavr against the emulated AT45DB321D
// (tools/avr_pil/at45db321d.h), driven by apm25_dataflash_exercise.elf over UART0: what the test writes
// through the LogStore functions must come back byte for byte, land in the pages the layout says
// (docs/logging.md), survive a reset of the processor and a power cut at any point, wrap around the ring
// of data pages dropping the oldest logs, and be gone after an erase; no append may keep the processor
// for milliseconds, and the driver must never send the chip a command it may not take while busy (the
// part counts those). What survives the ring is checked against RingModel, the test's own account of the
// documented rule, and the bytes against the test's copy of what it wrote.
#include <unistd.h>

#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "at45db321d.h"
#include "emulated_parts.h"

extern "C" const char* __asan_default_options() { return "detect_leaks=0"; }  // simavr's loader leaks

namespace {

constexpr avr_cycle_count_t kCyclesPerMs = 16000;
constexpr uint32_t kPageData = 512;

struct Rig {
  explicit Rig(uint32_t pages = parts::At45db321d::kPages) : flash(pages) {}
  avr_t* avr = nullptr;
  parts::At45db321d flash;
  std::vector<uint8_t> rx;
  std::deque<uint8_t> tx;
  avr_irq_t* uart_in = nullptr;
  avr_cycle_count_t next_feed = 0;
  avr_cycle_count_t cut_at = ~avr_cycle_count_t{0};  // run_until() stops there: the power goes
  bool cut = false;

  bool load(const char* elf = DATAFLASH_EXERCISE_ELF) {
    avr = parts::load_atmega2560(elf);
    if (!avr) return false;
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(
        avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
        [](avr_irq_t*, uint32_t value, void* self) { static_cast<Rig*>(self)->rx.push_back(static_cast<uint8_t>(value)); },
        this);
    uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
    return uart_in != nullptr && flash.attach(avr);
  }
  // Runs until n bytes of answer arrived (feeding the command at about the line's 1 Mbaud), at most ms.
  bool run_until(size_t n, double ms = 200.0) {
    const avr_cycle_count_t limit = avr->cycle + static_cast<avr_cycle_count_t>(ms * kCyclesPerMs);
    while (rx.size() < n && avr->cycle < limit) {
      if (avr->cycle >= cut_at) {
        cut = true;
        return false;
      }
      if (!tx.empty() && avr->cycle >= next_feed) {
        avr_raise_irq(uart_in, tx.front());
        tx.pop_front();
        next_feed = avr->cycle + 200;
      }
      if (avr_run(avr) == cpu_Crashed) return false;
    }
    return rx.size() >= n;
  }
  // Boots the image; its 'B' answer.
  int boot() {
    rx.clear();
    if (!run_until(2, 2000.0) || rx[0] != 'B') return -1;
    const int started = rx[1];
    rx.clear();
    return started;
  }
  std::vector<uint8_t> call(std::vector<uint8_t> command, size_t answer) {
    rx.clear();
    tx.insert(tx.end(), command.begin(), command.end());
    if (!run_until(answer) && cut) return std::vector<uint8_t>(answer, 0);
    EXPECT_GE(rx.size(), answer) << "no answer to '" << static_cast<char>(command[0]) << "'";
    EXPECT_EQ(rx.empty() ? 0 : rx[0], command[0] + ('a' - 'A'));
    rx.resize(std::max(rx.size(), answer), 0);
    return rx;
  }
  // The supply lost and back: the part's buffers and a page program in progress (torn), the processor
  // reset with it.
  void power_cycle() {
    flash.power_cut();
    avr_reset(avr);
    rx.clear();
    tx.clear();
    cut = false;
    cut_at = ~avr_cycle_count_t{0};
  }
  static void put(std::vector<uint8_t>& v, uint32_t x, int bytes) {
    for (int i = 0; i < bytes; ++i) v.push_back(static_cast<uint8_t>(x >> (8 * i)));
  }
  static uint32_t get(const std::vector<uint8_t>& v, size_t at, int bytes) {
    uint32_t x = 0;
    for (int i = 0; i < bytes; ++i) x |= static_cast<uint32_t>(v.at(at + i)) << (8 * i);
    return x;
  }

  bool open(uint32_t time) {
    std::vector<uint8_t> c{'O'};
    put(c, time, 4);
    return call(c, 2).at(1) == 1;
  }
  // One append: bytes taken and the call's duration (us).
  std::pair<size_t, uint32_t> append(const uint8_t* data, size_t n) {
    std::vector<uint8_t> c{'W', static_cast<uint8_t>(n)};
    c.insert(c.end(), data, data + n);
    const std::vector<uint8_t> a = call(c, 4);
    return {a.at(1), get(a, 2, 2)};
  }
  // Appends all of data in chunks, running the processor between short appends as a flight loop would;
  // the longest append (us) and the number of short ones.
  // Stops early when 100 ms pass without a byte taken (a full ring) or the power is cut; returns the
  // bytes taken.
  size_t append_all(const std::vector<uint8_t>& data, uint32_t* longest_us, int* short_appends) {
    size_t at = 0;
    int idle_ms = 0;
    while (at < data.size() && idle_ms < 100 && !cut) {
      const size_t n = std::min<size_t>(100, data.size() - at);
      const auto r = append(&data[at], n);
      *longest_us = std::max(*longest_us, r.second);
      if (r.first < n) {
        ++*short_appends;
        run_until(~size_t{0}, 1.0);  // a millisecond later
      }
      idle_ms = r.first == 0 ? idle_ms + 1 : 0;
      at += r.first;
    }
    return at;
  }
  void close() { call({'C'}, 1); }
  uint16_t count() { return static_cast<uint16_t>(get(call({'N'}, 3), 1, 2)); }
  // An entry, asking again for up to 100 ms while the chip is busy.
  bool entry(uint16_t id, uint32_t* size, uint32_t* time) {
    std::vector<uint8_t> c{'E'};
    put(c, id, 2);
    for (int tries = 0; tries < 100; ++tries) {
      const std::vector<uint8_t> a = call(c, 10);
      *size = get(a, 2, 4);
      *time = get(a, 6, 4);
      if (a.at(1) == 1) return true;
      run_until(~size_t{0}, 1.0);
    }
    return false;
  }
  std::vector<uint8_t> read(uint16_t id, uint32_t ofs, uint8_t n) {
    std::vector<uint8_t> c{'R'};
    put(c, id, 2);
    put(c, ofs, 4);
    c.push_back(n);
    rx.clear();
    tx.insert(tx.end(), c.begin(), c.end());
    EXPECT_TRUE(run_until(2));
    if (rx.size() < 2) return {};
    const size_t got = rx.at(1);
    EXPECT_TRUE(run_until(2 + got));
    return std::vector<uint8_t>(rx.begin() + 2, rx.begin() + 2 + static_cast<long>(got));
  }
  // The whole log through read() in 90-byte pieces (LOG_DATA's), asking again while the chip is busy.
  std::vector<uint8_t> read_all(uint16_t id, uint32_t size) {
    std::vector<uint8_t> out;
    int busy = 0;
    while (out.size() < size && busy < 1000) {
      const std::vector<uint8_t> piece = read(id, static_cast<uint32_t>(out.size()), 90);
      if (piece.empty()) {
        ++busy;
        run_until(~size_t{0}, 1.0);
      }
      out.insert(out.end(), piece.begin(), piece.end());
    }
    return out;
  }
  bool erase() { return call({'X'}, 2).at(1) == 1; }
};

std::vector<uint8_t> random_bytes(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> v(n);
  for (auto& b : v) b = static_cast<uint8_t>(rng());
  return v;
}

// The documented layout (docs/logging.md), written into the part's memory by the test itself.
void put16(uint8_t* p, uint32_t v) {
  p[0] = static_cast<uint8_t>(v);
  p[1] = static_cast<uint8_t>(v >> 8);
}
struct Slot {
  uint16_t serial, start;
  uint32_t time;
};
void write_index(parts::At45db321d& flash, uint32_t copy, uint16_t generation, uint16_t next, uint16_t update,
                 const std::vector<Slot>& slots) {
  uint8_t* p = flash.page(copy);
  std::memset(p, 0xFF, parts::At45db321d::kPageSize);
  std::memcpy(p, "QLG2", 4);
  put16(p + 4, generation);
  put16(p + 6, next);
  for (const Slot& s : slots) {
    uint8_t* q = p + 8 + 8 * (s.serial & 63u);
    put16(q, s.serial);
    put16(q + 2, s.start);
    put16(q + 4, s.time & 0xFFFFu);
    put16(q + 6, s.time >> 16);
  }
  put16(p + 520, update);
  uint32_t sum = 0x5149;
  for (int i = 4; i < 522; i += 2) sum += p[i] | (p[i + 1] << 8);
  put16(p + 522, sum);
}
void write_data_page(parts::At45db321d& flash, uint32_t page, uint16_t generation, uint16_t serial, uint16_t sequence,
                     const uint8_t* data, uint16_t used) {
  uint8_t* p = flash.page(page);
  std::memcpy(p, data, used);
  put16(p + 512, 0x5144u + generation + serial + sequence + used);
  put16(p + 514, generation);
  put16(p + 516, serial);
  put16(p + 518, sequence);
  put16(p + 520, used);
}

// The ring's rule as docs/logging.md states it, kept apart from the driver: logs follow each other in
// the data pages 2..pages-1; a page is programmed when it is full and more bytes come, or at close (an
// empty log gets one page); the log whose first page is programmed is dropped; when the next page is the
// open log's own first page the log ends there; a 65th log drops the oldest. Each log keeps the bytes
// the test wrote.
struct RingModel {
  struct Log {
    uint32_t start, time;
    std::vector<uint8_t> bytes;
  };
  explicit RingModel(uint32_t pages) : end(pages) {}
  uint32_t end, page = 2, fill = 0;
  bool open = false, full = false;
  std::deque<Log> logs;

  void program_page() {
    if (logs.size() > 1 && page == logs.front().start) logs.pop_front();
    page = page + 1 == end ? 2 : page + 1;
    fill = 0;
    full = page == logs.back().start;
  }
  void open_log(uint32_t time) {
    if (logs.size() == 64) logs.pop_front();
    logs.push_back({page, time, {}});
    open = true;
    full = false;
    fill = 0;
  }
  size_t append(const uint8_t* data, size_t n) {
    size_t taken = 0;
    while (taken < n && !full) {
      if (fill == kPageData) {
        program_page();
        continue;
      }
      const size_t k = std::min<size_t>(kPageData - fill, n - taken);
      logs.back().bytes.insert(logs.back().bytes.end(), data + taken, data + taken + k);
      fill += static_cast<uint32_t>(k);
      taken += k;
    }
    return taken;
  }
  void close() {
    if (!full && (fill > 0 || logs.back().bytes.empty())) program_page();
    open = false;
  }
  std::vector<uint32_t> times() const {
    std::vector<uint32_t> t;
    for (const Log& l : logs) t.push_back(l.time);
    return t;
  }
};

// tools/avr_pil/dataflash_logs.py, the layout read in Python apart from the driver, on the part's memory:
// its list has `logs.size()` lines and log i+1 extracts to logs[i].
void expect_reader_gets(const parts::At45db321d& flash, const std::vector<std::vector<uint8_t>>& logs) {
  // One file per test process: ctest runs the cases of this binary in parallel.
  const std::string image = ::testing::TempDir() + "/dataflash_reader_" + std::to_string(getpid()) + ".img";
  const std::string out = image + ".log";
  ASSERT_TRUE(flash.save(image));
  const std::string list = std::string(DATAFLASH_LOGS_PY) + " " + image + " list > " + out;
  ASSERT_EQ(std::system(list.c_str()), 0) << list;
  std::ifstream listed(out);
  size_t lines = 0;
  for (std::string line; std::getline(listed, line);) ++lines;
  EXPECT_EQ(lines, logs.size()) << list;
  for (size_t i = 0; i < logs.size(); ++i) {
    const std::string extract = std::string(DATAFLASH_LOGS_PY) + " " + image + " extract " + std::to_string(i + 1) + " " + out;
    ASSERT_EQ(std::system(extract.c_str()), 0) << extract;
    std::ifstream f(out, std::ios::binary);
    const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_EQ(bytes, logs[i]) << extract;
  }
  std::remove(image.c_str());
  std::remove(out.c_str());
}

class Apm25DataFlash : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(rig.load()) << "cannot load " << DATAFLASH_EXERCISE_ELF << " or attach the part";
  }
  void TearDown() override {
    EXPECT_EQ(rig.flash.errors(), 0u) << "the driver sent commands the chip does not take (while busy?)";
    if (rig.avr) avr_terminate(rig.avr);
  }
  Rig rig;
};

TEST_F(Apm25DataFlash, FormatsAFreshChipAndHoldsNoLog) {
  ASSERT_EQ(rig.boot(), 1);
  EXPECT_EQ(std::memcmp(rig.flash.page(0), "QLG2", 4), 0) << "index page not written";
  EXPECT_EQ(rig.count(), 0);
  EXPECT_TRUE(rig.read(1, 0, 90).empty());
}

// What an append costs the flight loop (docs/logging.md, "Cost on the ATmega2560"): a call and a byte,
// from a 1-byte and a 255-byte append into the chip's buffer (no page program in between), timed by the
// image's micros() (1 us = 16 cycles). The byte loop keeps MSPIM's transmit buffer full: 27 cycles a byte
// on simavr (16 on the wire, its receive flag 16 cycles after each read), 46 with a call per byte that
// waits for each answer before the next byte goes.
TEST_F(Apm25DataFlash, AnAppendCostsACallAndUnder32CyclesAByte) {
  ASSERT_EQ(rig.boot(), 1);
  ASSERT_TRUE(rig.open(0));
  for (int i = 0; i < 4; ++i) {  // open()'s index work, done over the calls that follow it
    rig.run_until(~size_t{0}, 20.0);
    rig.count();
  }
  const std::vector<uint8_t> data = random_bytes(255, 7);
  const auto one = rig.append(data.data(), 1);
  const auto many = rig.append(data.data(), 255);
  ASSERT_EQ(one.first, 1u);
  ASSERT_EQ(many.first, 255u);
  const double per_byte = 16.0 * (many.second - one.second) / 254.0;
  const double per_call = 16.0 * one.second - per_byte;
  std::printf("append: %.1f cycles a byte, %.0f cycles a call (1 byte %u us, 255 bytes %u us)\n", per_byte, per_call,
              one.second, many.second);
  EXPECT_LT(per_byte, 32.0);
}

TEST_F(Apm25DataFlash, WritesReadsBackAndKeepsTheLayout) {
  ASSERT_EQ(rig.boot(), 1);
  const std::vector<uint8_t> a = random_bytes(5000, 1), b = random_bytes(1300, 2);
  uint32_t longest = 0;
  int short_appends = 0;
  ASSERT_TRUE(rig.open(1700000000u));
  rig.append_all(a, &longest, &short_appends);
  rig.close();
  ASSERT_TRUE(rig.open(1700000100u));
  rig.append_all(b, &longest, &short_appends);
  // Log 2 stays open: its last bytes are still in the chip's buffer, and readable from there.
  ASSERT_EQ(rig.count(), 2);
  uint32_t size, time;
  ASSERT_TRUE(rig.entry(1, &size, &time));
  EXPECT_EQ(size, a.size());
  EXPECT_EQ(time, 1700000000u);
  ASSERT_TRUE(rig.entry(2, &size, &time));
  EXPECT_EQ(size, b.size());
  EXPECT_EQ(time, 1700000100u);
  EXPECT_EQ(rig.read_all(1, static_cast<uint32_t>(a.size())), a);
  EXPECT_EQ(rig.read_all(2, static_cast<uint32_t>(b.size())), b);
  rig.close();
  EXPECT_EQ(rig.read_all(2, static_cast<uint32_t>(b.size())), b);

  // The layout, read from the part's memory: log 1 from page 2 (10 pages, the last with 392 bytes),
  // log 2 from page 12; 512 data bytes per page.
  for (uint32_t i = 0; i < a.size(); ++i) ASSERT_EQ(rig.flash.page(2 + i / kPageData)[i % kPageData], a[i]) << i;
  for (uint32_t i = 0; i < b.size(); ++i) ASSERT_EQ(rig.flash.page(12 + i / kPageData)[i % kPageData], b[i]) << i;
  // Five appends of 100 bytes fill a buffer faster than a page programs (17 ms): the driver must have
  // refused bytes rather than wait, and never held the processor for a millisecond.
  EXPECT_GT(short_appends, 0);
  EXPECT_LT(longest, 1000u) << "an append took " << longest << " us";
  std::printf("longest append of <= 100 bytes: %u us, %d short appends\n", longest, short_appends);
}

TEST_F(Apm25DataFlash, KeepsWhatReachedTheFlashOverAReset) {
  ASSERT_EQ(rig.boot(), 1);
  const std::vector<uint8_t> a = random_bytes(2000, 3), b = random_bytes(1700, 4);
  uint32_t longest = 0;
  int short_appends = 0;
  ASSERT_TRUE(rig.open(5));
  rig.append_all(a, &longest, &short_appends);
  rig.close();
  ASSERT_TRUE(rig.open(6));
  rig.append_all(b, &longest, &short_appends);
  rig.run_until(~size_t{0}, 50.0);  // the last full page programmed
  avr_reset(rig.avr);               // no close(): the board lost power in flight
  ASSERT_EQ(rig.boot(), 1);
  ASSERT_EQ(rig.count(), 2);
  uint32_t size, time;
  ASSERT_TRUE(rig.entry(1, &size, &time));
  EXPECT_EQ(size, a.size());
  EXPECT_EQ(rig.read_all(1, size), a);
  // Log 2 keeps its full pages (three of 512 bytes); the last 164 bytes were still in the chip's buffer.
  ASSERT_TRUE(rig.entry(2, &size, &time));
  EXPECT_EQ(size, 3 * kPageData);
  EXPECT_EQ(time, 6u);
  EXPECT_EQ(rig.read_all(2, size), std::vector<uint8_t>(b.begin(), b.begin() + 3 * kPageData));
  // A new log starts after it.
  ASSERT_TRUE(rig.open(7));
  rig.append_all(random_bytes(10, 5), &longest, &short_appends);
  rig.close();
  EXPECT_EQ(rig.count(), 3);
  ASSERT_TRUE(rig.entry(2, &size, &time));
  EXPECT_EQ(size, 3 * kPageData);
}

TEST_F(Apm25DataFlash, EraseForgetsEveryLog) {
  ASSERT_EQ(rig.boot(), 1);
  uint32_t longest = 0;
  int short_appends = 0;
  ASSERT_TRUE(rig.open(1));
  rig.append_all(random_bytes(3000, 6), &longest, &short_appends);
  EXPECT_FALSE(rig.erase()) << "erase while a log is open";
  rig.close();
  ASSERT_TRUE(rig.erase());
  EXPECT_EQ(rig.count(), 0);
  // A shorter log in the same pages: the old pages after it do not belong to it.
  const std::vector<uint8_t> c = random_bytes(700, 7);
  ASSERT_TRUE(rig.open(2));
  rig.append_all(c, &longest, &short_appends);
  rig.close();
  rig.run_until(~size_t{0}, 50.0);
  avr_reset(rig.avr);
  ASSERT_EQ(rig.boot(), 1);
  ASSERT_EQ(rig.count(), 1);
  uint32_t size, time;
  ASSERT_TRUE(rig.entry(1, &size, &time));
  EXPECT_EQ(size, c.size());
  EXPECT_EQ(rig.read_all(1, size), c);
}

// The full part: a chip whose two logs hold pages 2..8150 (written here in the documented layout, as
// 8149 pages of flight would leave it). A third log of 40 000 bytes (79 pages) takes pages 8151..8191,
// then wraps to page 2, the first log's first page: the first log is dropped, the second is untouched,
// and the third reads back in order across the chip's end, also after a reset.
TEST_F(Apm25DataFlash, WrapsPastTheChipsLastPageAndDropsTheOldestLog) {
  const std::vector<uint8_t> fill = random_bytes(kPageData, 9);
  for (uint16_t k = 0; k < 4000; ++k) write_data_page(rig.flash, 2u + k, 0, 0, k, fill.data(), 512);
  for (uint16_t k = 0; k < 4149; ++k) write_data_page(rig.flash, 4002u + k, 0, 1, k, fill.data(), k == 4148 ? 100 : 512);
  write_index(rig.flash, 0, 0, 2, 1, {{0, 2, 1000}, {1, 4002, 2000}});
  ASSERT_EQ(rig.boot(), 1);
  ASSERT_EQ(rig.count(), 2);
  uint32_t size, time;
  ASSERT_TRUE(rig.entry(1, &size, &time));
  EXPECT_EQ(size, 4000u * kPageData);
  EXPECT_EQ(time, 1000u);
  ASSERT_TRUE(rig.entry(2, &size, &time));
  EXPECT_EQ(size, 4148u * kPageData + 100);

  const std::vector<uint8_t> c = random_bytes(40000, 10);
  uint32_t longest = 0;
  int short_appends = 0;
  ASSERT_TRUE(rig.open(3000));
  ASSERT_EQ(rig.append_all(c, &longest, &short_appends), c.size());
  rig.close();
  for (int boot = 0; boot < 2; ++boot) {
    ASSERT_EQ(rig.count(), 2) << "boot " << boot;
    ASSERT_TRUE(rig.entry(1, &size, &time));
    EXPECT_EQ(size, 4148u * kPageData + 100);
    EXPECT_EQ(time, 2000u);
    ASSERT_TRUE(rig.entry(2, &size, &time));
    EXPECT_EQ(size, c.size());
    EXPECT_EQ(time, 3000u);
    EXPECT_EQ(rig.read_all(2, size), c);
    EXPECT_EQ(rig.read(1, 4148u * kPageData, 90), std::vector<uint8_t>(fill.begin(), fill.begin() + 90));
    rig.run_until(~size_t{0}, 50.0);
    avr_reset(rig.avr);
    ASSERT_EQ(rig.boot(), 1);
  }
  // In the part's memory: 41 pages at the chip's end, the rest from page 2.
  for (uint32_t i = 0; i < c.size(); ++i) {
    const uint32_t k = i / kPageData;
    ASSERT_EQ(rig.flash.page(k < 41 ? 8151 + k : 2 + (k - 41))[i % kPageData], c[i]) << i;
  }
  EXPECT_EQ(rig.flash.page(40)[512 + 4], 0) << "the first log's pages past the third's are left as they were";
  std::vector<uint8_t> second;
  for (uint16_t k = 0; k < 4149; ++k) second.insert(second.end(), fill.begin(), fill.begin() + (k == 4148 ? 100 : 512));
  expect_reader_gets(rig.flash, {second, c});
  EXPECT_LT(longest, 1000u) << "an append took " << longest << " us";
}

TEST_F(Apm25DataFlash, ReportsNoChipWhenNoneAnswers) {
  avr_terminate(rig.avr);
  rig.avr = parts::load_atmega2560(DATAFLASH_EXERCISE_ELF);
  ASSERT_NE(rig.avr, nullptr);
  uint32_t flags = 0;
  avr_ioctl(rig.avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
  avr_irq_register_notify(
      avr_io_getirq(rig.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
      [](avr_irq_t*, uint32_t value, void* self) { static_cast<Rig*>(self)->rx.push_back(static_cast<uint8_t>(value)); },
      &rig);
  rig.uart_in = avr_io_getirq(rig.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
  parts::At45db321d floating;
  floating.set_absent(true);
  ASSERT_TRUE(floating.attach(rig.avr));
  ASSERT_EQ(rig.boot(), 0);
  EXPECT_EQ(rig.count(), 0);
  EXPECT_FALSE(rig.open(1));
}

// Logs written through the driver and the model side by side, on a part of kChipPages pages with the
// driver built for that size.
template <uint32_t kChipPages>
class RingTest : public ::testing::Test {
 protected:
  const char* elf() const { return kChipPages == 64 ? DATAFLASH_EXERCISE_SMALL_ELF : DATAFLASH_EXERCISE_ELF; }
  void SetUp() override {
    ASSERT_TRUE(rig.load(elf())) << "cannot load " << elf();
    ASSERT_EQ(rig.boot(), 1);
  }
  void TearDown() override {
    EXPECT_EQ(rig.flash.errors(), 0u) << "the driver sent commands the chip does not take (while busy?)";
    if (rig.avr) avr_terminate(rig.avr);
  }
  // One whole log through the driver and the model; the bytes the driver took.
  size_t write_log(uint32_t time, const std::vector<uint8_t>& data) {
    EXPECT_TRUE(rig.open(time));
    model.open_log(time);
    const size_t taken = rig.append_all(data, &longest, &short_appends);
    EXPECT_EQ(model.append(data.data(), taken), taken) << "the driver took bytes the model has no room for";
    rig.close();
    model.close();
    return taken;
  }
  // The driver's list against the model's: count, order (times), sizes and every byte.
  void expect_model(const char* when) {
    ASSERT_EQ(rig.count(), model.logs.size()) << when;
    for (size_t i = 0; i < model.logs.size(); ++i) {
      const uint16_t id = static_cast<uint16_t>(i + 1);
      uint32_t size, time;
      ASSERT_TRUE(rig.entry(id, &size, &time)) << when;
      EXPECT_EQ(time, model.logs[i].time) << when << ", log " << id;
      ASSERT_EQ(size, model.logs[i].bytes.size()) << when << ", log " << id;
      EXPECT_EQ(rig.read_all(id, size), model.logs[i].bytes) << when << ", log " << id;
    }
  }
  std::vector<std::vector<uint8_t>> model_bytes() const {
    std::vector<std::vector<uint8_t>> logs;
    for (const RingModel::Log& l : model.logs) logs.push_back(l.bytes);
    return logs;
  }
  void reset_and_boot() {
    rig.run_until(~size_t{0}, 50.0);
    avr_reset(rig.avr);
    ASSERT_EQ(rig.boot(), 1);
  }
  Rig rig{kChipPages};
  RingModel model{kChipPages};
  uint32_t longest = 0;
  int short_appends = 0;
};

// The ring on a 64-page part (data pages 2..63, 31 744 bytes).
class Apm25DataFlashRing : public RingTest<64> {};
// The full part.
class Apm25DataFlashLogs : public RingTest<parts::At45db321d::kPages> {};

// Four logs fill 58 of the 62 data pages; the fifth wraps past page 63 to page 2 and drops the first; the
// sixth drops the second and ends just before the third; the seventh drops the third.
TEST_F(Apm25DataFlashRing, FillingTheChipDropsTheOldestLogs) {
  const size_t sizes[6] = {9000, 7000, 5000, 8000, 6000, 12000};
  for (uint32_t i = 0; i < 6; ++i) {
    ASSERT_EQ(write_log(i + 1, random_bytes(sizes[i], 100 + i)), sizes[i]);
    expect_model(("after log " + std::to_string(i + 1)).c_str());
  }
  EXPECT_EQ(model.times(), (std::vector<uint32_t>{3, 4, 5, 6}));  // the rule, worked by hand
  // Log 5 lies in pages 60..63 and 2..9.
  const std::vector<uint8_t> five = random_bytes(6000, 104);
  for (uint32_t i = 0; i < five.size(); ++i) {
    const uint32_t k = i / kPageData;
    ASSERT_EQ(rig.flash.page(k < 4 ? 60 + k : 2 + (k - 4))[i % kPageData], five[i]) << i;
  }
  reset_and_boot();
  expect_model("after a reset");
  expect_reader_gets(rig.flash, model_bytes());
  ASSERT_EQ(write_log(7, random_bytes(3000, 107)), 3000u);
  EXPECT_EQ(model.times(), (std::vector<uint32_t>{4, 5, 6, 7}));
  expect_model("after log 7");
  EXPECT_LT(longest, 1000u) << "an append took " << longest << " us";
  std::printf("ring: longest append of <= 100 bytes %u us, %d short appends\n", longest, short_appends);
}

// More than 64 logs: the 65th drops the first although the pages have room.
TEST_F(Apm25DataFlashLogs, KeepsAtMost64Logs) {
  for (uint32_t i = 0; i < 70; ++i) write_log(i + 1, random_bytes(10 + i, 200 + i));
  EXPECT_EQ(model.times().front(), 7u);
  EXPECT_EQ(model.logs.size(), 64u);
  expect_model("after 70 logs");
  reset_and_boot();
  expect_model("after a reset");
}

// One log larger than the ring: it drops every older log, keeps its first 62 pages (its ULog header and
// definitions) and takes nothing more, as ArduPilot's block logger stops at "chip full"; the next log
// drops it.
TEST_F(Apm25DataFlashRing, ALogLargerThanTheChipKeepsItsBeginning) {
  ASSERT_EQ(write_log(1, random_bytes(3000, 300)), 3000u);
  const std::vector<uint8_t> big = random_bytes(40000, 301);
  ASSERT_EQ(write_log(2, big), 62u * kPageData);
  EXPECT_EQ(model.times(), (std::vector<uint32_t>{2}));
  expect_model("after the large log");
  expect_reader_gets(rig.flash, model_bytes());
  reset_and_boot();
  expect_model("after a reset");
  ASSERT_EQ(write_log(3, random_bytes(1000, 302)), 1000u);
  EXPECT_EQ(model.times(), (std::vector<uint32_t>{3}));
  expect_model("after the next log");
}

// The power goes while a page of the open log is programmed: that page is torn (the part erases it from
// the byte its programming had reached), the log keeps its two pages before it, the closed log is whole,
// and the next log takes the torn page.
TEST_F(Apm25DataFlashRing, RecoversFromAPowerCutDuringAPageProgram) {
  const std::vector<uint8_t> a = random_bytes(5000, 400), b = random_bytes(5000, 401);
  ASSERT_EQ(write_log(1, a), a.size());
  ASSERT_TRUE(rig.open(2));
  const uint32_t b_start = 12, torn = b_start + 2;
  size_t at = 0;
  while (!(rig.flash.programming() && rig.flash.last_program_page() == torn) && at < b.size()) {
    at += rig.append(&b[at], std::min<size_t>(100, b.size() - at)).first;
  }
  ASSERT_TRUE(rig.flash.programming()) << "no program of page " << torn;
  rig.cut_at = rig.avr->cycle + 5 * kCyclesPerMs;  // 5 ms into the 17 ms program
  rig.run_until(~size_t{0}, 10.0);
  rig.power_cycle();
  EXPECT_EQ(rig.flash.torn_pages(), 1u);
  EXPECT_EQ(rig.flash.page(torn)[527], 0xFF) << "page " << torn << " not torn";
  ASSERT_EQ(rig.boot(), 1);
  model.logs.push_back({b_start, 2, std::vector<uint8_t>(b.begin(), b.begin() + 2 * kPageData)});
  model.page = torn;
  expect_model("after the power cut");
  expect_reader_gets(rig.flash, model_bytes());
  const std::vector<uint8_t> c = random_bytes(2000, 402);
  ASSERT_EQ(write_log(3, c), c.size());
  expect_model("after the next log");
  EXPECT_EQ(std::memcmp(rig.flash.page(torn), c.data(), kPageData), 0) << "the next log does not start on the torn page";
}

// The power goes while open() programs the index copy that holds the new log's slot: that copy is torn,
// the other one (the index before the open) is taken at boot, the logs are whole and the new log, which
// had no page yet, is not there. The next log goes on from there.
TEST_F(Apm25DataFlashRing, RecoversFromAPowerCutDuringAnIndexUpdate) {
  ASSERT_EQ(write_log(1, random_bytes(3000, 500)), 3000u);
  ASSERT_EQ(write_log(2, random_bytes(2000, 501)), 2000u);
  ASSERT_TRUE(rig.open(3));
  const std::vector<uint8_t> c = random_bytes(600, 502);
  size_t at = 0;
  for (int tries = 0; tries < 100 && !(rig.flash.programming() && rig.flash.last_program_page() <= 1); ++tries) {
    at += rig.append(&c[at], 10).first;
    rig.run_until(~size_t{0}, 0.1);
  }
  ASSERT_TRUE(rig.flash.programming() && rig.flash.last_program_page() <= 1) << "no index program seen";
  const uint32_t copy = static_cast<uint32_t>(rig.flash.last_program_page());
  rig.cut_at = rig.avr->cycle + 8 * kCyclesPerMs;
  rig.run_until(~size_t{0}, 10.0);
  rig.power_cycle();
  EXPECT_EQ(rig.flash.torn_pages(), 1u);
  EXPECT_EQ(rig.flash.page(copy)[523], 0xFF) << "index copy " << copy << " not torn (its check word)";
  ASSERT_EQ(rig.boot(), 1);
  expect_model("after the power cut");
  expect_reader_gets(rig.flash, model_bytes());
  ASSERT_EQ(write_log(4, random_bytes(1500, 503)), 1500u);
  expect_model("after the next log");
  reset_and_boot();
  expect_model("after a reset");
}

// The power goes at 8 arbitrary moments while logs fill and wrap the ring (a fresh chip each time).
// After the reboot every log listed is in the order written and holds a prefix of its bytes: whole for a
// closed log, whole pages for the one open at the cut; every log the model held closed is there (a log
// the writer had dropped but not yet overwritten may come back, whole); a next log is written and read.
TEST(Apm25DataFlashPowerCut, AtAnyPointKeepsWholeLogs) {
  std::mt19937 rng(7);
  for (int run = 0; run < 8; ++run) {
    Rig rig{64};
    ASSERT_TRUE(rig.load(DATAFLASH_EXERCISE_SMALL_ELF));
    ASSERT_EQ(rig.boot(), 1);
    RingModel model{64};
    std::vector<std::vector<uint8_t>> written;  // by time - 1
    rig.cut_at = rig.avr->cycle + (700 + rng() % 900) * kCyclesPerMs;
    uint32_t longest = 0;
    int short_appends = 0;
    int open_at_cut = -1;
    for (uint32_t time = 1; !rig.cut; ++time) {
      written.push_back(random_bytes(2000 + rng() % 9000, 1000 * run + time));
      if (!rig.open(time) || rig.cut) break;
      model.open_log(time);
      const size_t taken = rig.append_all(written.back(), &longest, &short_appends);
      model.append(written.back().data(), taken);
      if (rig.cut) {
        open_at_cut = static_cast<int>(time);
        break;
      }
      rig.close();
      if (rig.cut) {
        open_at_cut = static_cast<int>(time);
        break;
      }
      model.close();
    }
    const double cut_ms = static_cast<double>(rig.avr->cycle) / kCyclesPerMs;
    const uint64_t torn = rig.flash.torn_pages();
    rig.power_cycle();
    ASSERT_EQ(rig.boot(), 1) << "run " << run;
    const uint16_t count = rig.count();
    std::vector<uint32_t> listed;
    for (uint16_t id = 1; id <= count; ++id) {
      uint32_t size, time;
      ASSERT_TRUE(rig.entry(id, &size, &time));
      ASSERT_TRUE(time >= 1 && time <= written.size()) << "run " << run << ": log " << id << " time " << time;
      const std::vector<uint8_t>& w = written[time - 1];
      ASSERT_LE(size, w.size()) << "run " << run << ": log of time " << time;
      EXPECT_EQ(rig.read_all(id, size), std::vector<uint8_t>(w.begin(), w.begin() + size)) << "run " << run;
      if (static_cast<int>(time) != open_at_cut) EXPECT_EQ(size, w.size()) << "run " << run << ": closed log " << time;
      if (static_cast<int>(time) == open_at_cut && size != w.size()) EXPECT_EQ(size % kPageData, 0u);
      EXPECT_TRUE(listed.empty() || time > listed.back()) << "run " << run << ": order";
      listed.push_back(time);
    }
    for (const RingModel::Log& l : model.logs) {
      if (static_cast<int>(l.time) == open_at_cut) continue;
      EXPECT_NE(std::find(listed.begin(), listed.end(), l.time), listed.end())
          << "run " << run << ": closed log " << l.time << " lost";
    }
    const std::vector<uint8_t> next = random_bytes(1800, 99);
    ASSERT_TRUE(rig.open(500));
    ASSERT_EQ(rig.append_all(next, &longest, &short_appends), next.size());
    rig.close();
    uint32_t size, time;
    ASSERT_TRUE(rig.entry(rig.count(), &size, &time));
    EXPECT_EQ(time, 500u);
    EXPECT_EQ(rig.read_all(rig.count(), size), next) << "run " << run;
    EXPECT_EQ(rig.flash.errors(), 0u);
    std::printf("run %d: cut at %.0f ms, %zu logs written, log %d open, %u listed after it, %llu page torn\n", run,
                cut_ms, written.size(), open_at_cut, count, static_cast<unsigned long long>(rig.flash.torn_pages() - torn));
    avr_terminate(rig.avr);
  }
}

TEST(At45db321dFile, PersistsTheMemory) {
  const std::string path = ::testing::TempDir() + "/at45db321d_" + std::to_string(getpid()) + ".bin";
  parts::At45db321d a;
  a.page(8191)[527] = 0x5A;
  a.page(0)[0] = 0x11;
  ASSERT_TRUE(a.save(path));
  parts::At45db321d b;
  ASSERT_TRUE(b.load(path));
  EXPECT_EQ(b.page(8191)[527], 0x5A);
  EXPECT_EQ(b.page(0)[0], 0x11);
  EXPECT_EQ(b.page(5)[3], 0xFF);
  EXPECT_FALSE(b.load(path + ".missing"));
}

}  // namespace
