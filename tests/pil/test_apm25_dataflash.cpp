// The APM 2.5's DataFlash log store (hal/avr/dataflash.cpp) on simavr against the emulated AT45DB321D
// (tools/avr_pil/at45db321d.h), driven by apm25_dataflash_exercise.elf over UART0: what the test writes
// through the LogStore functions must come back byte for byte, land in the pages the layout says
// (docs/logging.md), survive a reset of the processor, end at the chip's last page, and be gone after an
// erase; no append may keep the processor for milliseconds, and the driver must never send the chip a
// command it may not take while busy (the part counts those).
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#include <gtest/gtest.h>

#include <cstring>
#include <deque>
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
  avr_t* avr = nullptr;
  parts::At45db321d flash;
  std::vector<uint8_t> rx;
  std::deque<uint8_t> tx;
  avr_irq_t* uart_in = nullptr;
  avr_cycle_count_t next_feed = 0;

  bool load() {
    avr = parts::load_atmega2560(DATAFLASH_EXERCISE_ELF);
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
    EXPECT_TRUE(run_until(answer)) << "no answer to '" << static_cast<char>(command[0]) << "'";
    EXPECT_EQ(rx.empty() ? 0 : rx[0], command[0] + ('a' - 'A'));
    return rx;
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
  void append_all(const std::vector<uint8_t>& data, uint32_t* longest_us, int* short_appends) {
    size_t at = 0;
    while (at < data.size()) {
      const size_t n = std::min<size_t>(100, data.size() - at);
      const auto r = append(&data[at], n);
      *longest_us = std::max(*longest_us, r.second);
      if (r.first < n) {
        ++*short_appends;
        avr_cycle_count_t until = avr->cycle + kCyclesPerMs;  // a millisecond later
        while (avr->cycle < until) ASSERT_NE(avr_run(avr), cpu_Crashed);
      }
      at += r.first;
    }
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
  EXPECT_EQ(std::memcmp(rig.flash.page(0), "QLG1", 4), 0) << "index page not written";
  EXPECT_EQ(rig.count(), 0);
  EXPECT_TRUE(rig.read(1, 0, 90).empty());
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

  // The layout, read from the part's memory: log 1 from page 1 (10 pages, the last with 392 bytes),
  // log 2 from page 11; 512 data bytes per page.
  for (uint32_t i = 0; i < a.size(); ++i) ASSERT_EQ(rig.flash.page(1 + i / kPageData)[i % kPageData], a[i]) << i;
  for (uint32_t i = 0; i < b.size(); ++i) ASSERT_EQ(rig.flash.page(11 + i / kPageData)[i % kPageData], b[i]) << i;
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

TEST_F(Apm25DataFlash, TheLogEndsAtTheChipsLastPage) {
  // A chip whose log 1 takes pages 1..8189 (written here in the documented layout, as 8189 full pages
  // would leave it): a new log gets pages 8190 and 8191, 1024 bytes, then appends take nothing.
  uint8_t* index = rig.flash.page(0);
  std::memset(index, 0xFF, parts::At45db321d::kPageSize);
  std::memcpy(index, "QLG1\0\0", 6);
  const uint8_t slot[8] = {1, 0, 0xFF, 0xFF, 0, 0, 0, 0};
  std::memcpy(index + 8, slot, 8);
  for (uint16_t p = 1; p <= 8189; ++p) {
    const uint16_t t[5] = {0x5144, 0, 1, static_cast<uint16_t>(p - 1), 512};
    std::memcpy(rig.flash.page(p) + 512, t, sizeof t);
  }
  ASSERT_EQ(rig.boot(), 1);
  ASSERT_EQ(rig.count(), 1);
  uint32_t size, time;
  ASSERT_TRUE(rig.entry(1, &size, &time));
  EXPECT_EQ(size, 8189u * kPageData);
  ASSERT_TRUE(rig.open(9));
  const std::vector<uint8_t> d = random_bytes(1500, 8);
  size_t taken = 0;
  for (int tries = 0; tries < 200 && taken < d.size(); ++tries) {
    const size_t n = std::min<size_t>(100, d.size() - taken);
    taken += rig.append(&d[taken], n).first;
    rig.run_until(~size_t{0}, 2.0);
  }
  EXPECT_EQ(taken, 2 * kPageData);
  rig.close();
  EXPECT_FALSE(rig.open(10)) << "a log opened on a full chip";
  ASSERT_TRUE(rig.entry(2, &size, &time));
  EXPECT_EQ(size, 2 * kPageData);
  EXPECT_EQ(rig.read_all(2, size), std::vector<uint8_t>(d.begin(), d.begin() + 2 * kPageData));
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

TEST(At45db321dFile, PersistsTheMemory) {
  const std::string path = ::testing::TempDir() + "/at45db321d.bin";
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
