// An emulated Atmel AT45DB321D DataFlash (4 MB: 8192 pages of 528 bytes, two 528-byte SRAM buffers) on
// the ATmega2560's USART3 in SPI master mode (MSPIM), chip select PA6, as on the APM 2.5 (ArduPilot's
// APM2 HAL: AVRSPI3DeviceDriver on PORTA6). One implementation for tools/avr_pil (the flown HIL image)
// and tests/pil/test_apm25_drivers.cpp (the driver's register-level test).
//
// simavr 1.6 has no MSPIM: its USART sends every byte written to UDR3 on UART_IRQ_OUTPUT and receives
// what UART_IRQ_INPUT pushes, each after cycles_per_byte. The part answers every byte it sees while
// selected with the byte the chip would shift out for it (full duplex), and sets the USART's byte time
// to MSPIM's: 8 SCK periods of 2 (UBRR3 + 1) cycles.
//
// Commands (AT45DB321D datasheet, 528-byte page mode; page address = bits 22..10, byte = bits 9..0):
//   0xD7 status register read        (0xB4 when ready: RDY, density 1101 = 32 Mbit, 528-byte pages)
//   0x9F manufacturer and device id  1F 27 01 00
//   0x84 / 0x87 buffer 1 / 2 write   3 address bytes (byte address), then data; allowed while busy
//   0xD4 / 0xD6 buffer 1 / 2 read    3 address bytes, 1 don't-care byte, then data; allowed while busy
//   0x83 / 0x86 buffer 1 / 2 to main memory page program with built-in erase, starts at CS high: tEP
//   0x53 / 0x55 main memory page to buffer 1 / 2 transfer, starts at CS high: tXFR
//   0xD2 main memory page read       3 address bytes, 4 don't-care bytes, then data (wraps in the page)
// A main-memory command while busy, or a buffer command on the buffer being programmed, is a protocol
// error of the driver: counted (errors()), not executed. Unknown opcodes are counted too.
// Timing: tEP page erase and programming 17 ms (typical; the maximum 40 ms with set_worst_case()),
// tXFR 200 us (maximum).
//
// The memory can persist in a file (load()/save()): 8192 x 528 bytes, page after page, as the chip holds
// them; a fresh chip (or a missing file) reads 0xFF.
//
// Size: the part can be made with fewer pages (a power of two), answering as the AT45DB321D otherwise;
// the page address wraps at its size. tests/pil/test_apm25_dataflash.cpp fills and wraps a 64-page part
// with a driver built for 64 pages, in seconds rather than the full part's minutes.
// Power: power_cut() is the supply lost: the SRAM buffers lose their contents and a page program in
// progress leaves its page torn: programmed up to the fraction of tEP elapsed, erased (0xFF) after it
// (the built-in erase comes first). The processor's reset is the test's (avr_reset).
#pragma once

#include <simavr/avr_ioport.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>
#include <simavr/sim_time.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace parts {

class At45db321d {
 public:
  static constexpr uint32_t kPages = 8192, kPageSize = 528;
  static constexpr uint8_t kStatusReady = 0xB4;

  explicit At45db321d(uint32_t pages = kPages) : pages_(pages), memory_(pages * kPageSize, 0xFF) {
    for (auto& b : buffer_) b.assign(kPageSize, 0);
  }
  At45db321d(const At45db321d&) = delete;  // the simavr hooks hold `this`
  At45db321d& operator=(const At45db321d&) = delete;

  // Before the AVR runs. False when the USART3 or port A IRQs cannot be found.
  bool attach(avr_t* avr) {
    avr_ = avr;
    avr_irq_t* cs = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('A'), IOPORT_IRQ_PIN6);
    avr_irq_t* mosi = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('3'), UART_IRQ_OUTPUT);
    miso_ = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('3'), UART_IRQ_INPUT);
    if (!cs || !mosi || !miso_) return false;
    miso_->flags &= static_cast<uint8_t>(~IRQ_FLAG_FILTERED);  // equal answers in a row must all arrive
    uint32_t flags = 0;  // no console echo of the bus bytes, no sleeping on UCSR3A polls
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('3'), &flags);
    for (avr_io_t* io = avr->io_port; io; io = io->next) {
      if (std::string(io->kind) == "uart" && reinterpret_cast<avr_uart_t*>(io)->name == '3') {
        uart_ = reinterpret_cast<avr_uart_t*>(io);
      }
    }
    if (!uart_) return false;
    avr_irq_register_notify(cs, &At45db321d::on_cs, this);
    avr_irq_register_notify(mosi, &At45db321d::on_mosi, this);
    return true;
  }

  void set_worst_case(bool on) { program_us_ = on ? 40000 : 17000; }
  // No chip on the bus: the USART still clocks every byte (as MSPIM does), MISO reads 0xFF (pulled up).
  void set_absent(bool on) { absent_ = on; }

  // The memory from a file of pages() x kPageSize bytes; false (memory left erased) when there is none or
  // it has another size.
  bool load(const std::string& path) {
    FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return false;
    std::vector<uint8_t> data(memory_.size());
    const size_t n = std::fread(data.data(), 1, data.size(), f);
    const bool longer = std::fgetc(f) != EOF;
    std::fclose(f);
    if (n != data.size() || longer) return false;
    memory_ = std::move(data);
    return true;
  }
  bool save(const std::string& path) const {
    FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return false;
    const bool ok = std::fwrite(memory_.data(), 1, memory_.size(), f) == memory_.size();
    return std::fclose(f) == 0 && ok;
  }

  uint32_t pages() const { return pages_; }
  const uint8_t* page(uint32_t p) const { return &memory_[p * kPageSize]; }
  uint8_t* page(uint32_t p) { return &memory_[p * kPageSize]; }
  const std::vector<uint8_t>& buffer(int i) const { return buffer_[i]; }
  bool busy() const { return avr_ && avr_->cycle < busy_until_; }
  uint64_t errors() const { return errors_; }
  uint64_t programs() const { return programs_; }
  uint64_t transfers() const { return transfers_; }
  uint64_t reads_while_busy() const { return reads_while_busy_; }
  // The page the latest program went to (-1: none yet) and whether it is still in progress.
  int64_t last_program_page() const { return last_program_page_; }
  bool programming() const { return busy() && programming_buffer_ >= 0; }

  void power_cut() {
    if (programming()) {
      const double done = static_cast<double>(avr_->cycle - program_start_) / static_cast<double>(busy_until_ - program_start_);
      uint8_t* p = page(static_cast<uint32_t>(last_program_page_));
      std::fill(p + static_cast<size_t>(done * kPageSize), p + kPageSize, 0xFF);
      ++torn_pages_;
    }
    busy_until_ = 0;
    programming_buffer_ = -1;
    selected_ = false;
    command_.clear();
    for (auto& b : buffer_) std::fill(b.begin(), b.end(), 0xA5);
  }
  uint64_t torn_pages() const { return torn_pages_; }

 private:
  static void on_cs(avr_irq_t*, uint32_t value, void* param) {
    auto* self = static_cast<At45db321d*>(param);
    const bool low = value == 0;
    if (!low && self->selected_) self->end_command();
    if (low && !self->selected_) self->command_.clear();
    self->selected_ = low;
  }

  static void on_mosi(avr_irq_t*, uint32_t value, void* param) {
    auto* self = static_cast<At45db321d*>(param);
    if (!self->selected_ && !self->absent_) return;
    // MSPIM: 8 bits at F_CPU / (2 (UBRR3 + 1)).
    const uint16_t ubrr = static_cast<uint16_t>(self->avr_->data[0x134] | (self->avr_->data[0x135] << 8));
    self->uart_->cycles_per_byte = 16u * (ubrr + 1u);
    avr_raise_irq(self->miso_, self->absent_ ? 0xFF : self->shift(static_cast<uint8_t>(value)));
  }

  uint32_t address() const {
    return (static_cast<uint32_t>(command_[1]) << 16) | (static_cast<uint32_t>(command_[2]) << 8) | command_[3];
  }
  uint32_t page_of(uint32_t a) const { return (a >> 10) & (pages_ - 1); }
  uint32_t byte_of(uint32_t a) const { return a & 0x3FF; }
  bool buffer_busy(int b) const { return busy() && programming_buffer_ == b; }

  // The byte the chip shifts out while it receives `in` as byte command_.size() of the command.
  uint8_t shift(uint8_t in) {
    command_.push_back(in);
    const size_t i = command_.size() - 1;
    const uint8_t op = command_[0];
    switch (op) {
      case 0xD7: return i == 0 ? 0 : static_cast<uint8_t>(busy() ? (kStatusReady & 0x7F) : kStatusReady);
      case 0x9F: {
        static const uint8_t kId[4] = {0x1F, 0x27, 0x01, 0x00};
        return i >= 1 && i <= 4 ? kId[i - 1] : 0;
      }
      case 0x84:
      case 0x87: {
        const int b = op == 0x84 ? 0 : 1;
        if (i == 3) cursor_ = byte_of(address());
        if (i >= 4) {
          if (buffer_busy(b)) return note_error();
          buffer_[b][cursor_] = in;
          cursor_ = (cursor_ + 1) % kPageSize;
        }
        return 0;
      }
      case 0xD4:
      case 0xD6: {
        const int b = op == 0xD4 ? 0 : 1;
        if (i == 3) cursor_ = byte_of(address());
        if (i < 5) return 0;
        if (buffer_busy(b)) return note_error();
        const uint8_t out = buffer_[b][cursor_];
        cursor_ = (cursor_ + 1) % kPageSize;
        return out;
      }
      case 0xD2: {
        if (i == 3) cursor_ = byte_of(address());
        if (i < 8) return 0;
        if (busy()) {
          ++reads_while_busy_;
          return note_error();
        }
        const uint8_t out = page(page_of(address()))[cursor_];
        cursor_ = (cursor_ + 1) % kPageSize;
        return out;
      }
      case 0x83: case 0x86: case 0x53: case 0x55:
        return 0;  // executed when CS goes high
      default:
        if (i == 0) ++errors_;
        return 0;
    }
  }

  void end_command() {
    if (command_.size() < 4) return;
    const uint8_t op = command_[0];
    const bool program = op == 0x83 || op == 0x86, transfer = op == 0x53 || op == 0x55;
    if (!program && !transfer) return;
    if (busy()) {
      note_error();
      return;
    }
    const int b = (op == 0x83 || op == 0x53) ? 0 : 1;
    uint8_t* p = page(page_of(address()));
    if (program) {
      std::copy(buffer_[b].begin(), buffer_[b].end(), p);
      ++programs_;
      programming_buffer_ = b;
      last_program_page_ = page_of(address());
      program_start_ = avr_->cycle;
      busy_until_ = avr_->cycle + avr_usec_to_cycles(avr_, program_us_);
    } else {
      std::copy(p, p + kPageSize, buffer_[b].begin());
      ++transfers_;
      programming_buffer_ = -1;
      busy_until_ = avr_->cycle + avr_usec_to_cycles(avr_, 200);
    }
  }

  uint8_t note_error() {
    ++errors_;
    return 0;
  }

  uint32_t pages_;
  avr_t* avr_ = nullptr;
  avr_uart_t* uart_ = nullptr;
  avr_irq_t* miso_ = nullptr;
  bool selected_ = false;
  bool absent_ = false;
  std::vector<uint8_t> command_;
  uint32_t cursor_ = 0;
  std::vector<uint8_t> memory_;
  std::vector<uint8_t> buffer_[2];
  avr_cycle_count_t busy_until_ = 0, program_start_ = 0;
  int64_t last_program_page_ = -1;
  uint64_t torn_pages_ = 0;
  int programming_buffer_ = -1;
  uint32_t program_us_ = 17000;
  uint64_t errors_ = 0, programs_ = 0, transfers_ = 0, reads_while_busy_ = 0;
};

}  // namespace parts
