// Register-level smoke test of the APM 2.5 board drivers on simavr (apm25_driver_smoke.elf). simavr
// emulates the ATmega2560's timers but none of the board's parts, so this checks what the chip sees:
// the ESC outputs' timer configuration (490 Hz, pulse widths for given commands, output pins) and the
// PPM decoder fed with a PPM-sum waveform on ICP5. The MPU-6000 and HMC5883L drivers are not exercised
// (no device answers; docs/targets.md).
#include <simavr/avr_timer.h>
#include <simavr/avr_uart.h>
#include <simavr/sim_avr.h>
#include <simavr/sim_cycle_timers.h>
#include <simavr/sim_elf.h>
#include <simavr/sim_io.h>
#include <simavr/sim_irq.h>

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

extern "C" const char* __asan_default_options() { return "detect_leaks=0"; }  // simavr's loader leaks

namespace {

constexpr double kF = 16e6;

struct Board {
  avr_t* avr = nullptr;
  std::vector<uint8_t> uart0;
  avr_irq_t* icp = nullptr;

  bool load() {
    elf_firmware_t fw;
    std::memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(DRIVER_SMOKE_ELF, &fw) != 0) return false;
    avr = avr_make_mcu_by_name("atmega2560");
    if (!avr) return false;
    avr_init(avr);
    avr->frequency = 16000000;
    avr->sleep = [](avr_t*, avr_cycle_count_t) {};  // no wall-clock pacing
    avr_load_firmware(avr, &fw);
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(
        avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
        [](avr_irq_t*, uint32_t value, void* self) { static_cast<Board*>(self)->uart0.push_back(static_cast<uint8_t>(value)); },
        this);
    icp = avr_io_getirq(avr, AVR_IOCTL_TIMER_GETIRQ('5'), TIMER_IRQ_IN_ICP);
    return icp != nullptr;
  }
  void run_until_cycle(avr_cycle_count_t cycle) {
    while (avr->cycle < cycle) {
      const int state = avr_run(avr);
      ASSERT_NE(state, cpu_Crashed);
    }
  }
  uint8_t reg8(uint16_t address) const { return avr->data[address]; }
  uint16_t reg16(uint16_t low) const { return static_cast<uint16_t>(avr->data[low] | (avr->data[low + 1] << 8)); }
};

class Apm25Drivers : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(board_.load()) << "cannot load " << DRIVER_SMOKE_ELF << " (make avr)";
    // Up to 1 s of AVR time for the bring-up (the MPU-6000 reset wait, the I2C timeouts).
    while (board_.reg8(0x3E) != 1 && board_.avr->cycle < 16000000u) {
      ASSERT_NE(avr_run(board_.avr), cpu_Crashed);
    }
    ASSERT_EQ(board_.reg8(0x3E), 1) << "the image did not reach its motor write (GPIOR0)";
  }
  Board board_;
};

TEST_F(Apm25Drivers, EscOutputsAt490HzWithTheCommandedPulses) {
  // Timer1 and Timer4: fast PWM mode 14 (WGM 1110, TOP = ICR), prescaler 8, non-inverting outputs.
  for (const uint16_t base : {0x80, 0xA0}) {
    const uint8_t a = board_.reg8(base), b = board_.reg8(base + 1);
    EXPECT_EQ(a & 0x03, 0x02) << std::hex << base;         // WGMn1:0 = 10
    EXPECT_EQ((b >> 3) & 0x03, 0x03) << std::hex << base;  // WGMn3:2 = 11
    EXPECT_EQ(b & 0x07, 0x02) << std::hex << base;         // CSn = 010: F_CPU / 8
  }
  EXPECT_EQ(board_.reg8(0x80) & 0xF0, 0xA0);  // COM1A1, COM1B1
  EXPECT_EQ(board_.reg8(0xA0) & 0x3C, 0x28);  // COM4B1, COM4C1
  const uint16_t top1 = board_.reg16(0x86), top4 = board_.reg16(0xA6);
  EXPECT_EQ(top1, top4);
  EXPECT_NEAR(kF / 8.0 / (top1 + 1.0), 490.0, 0.5);
  // Pulses (2 ticks per us): OUT1 0 -> 1000 us, OUT2 0.25 -> 1250, OUT3 0.5 -> 1500, OUT4 1 -> 2000.
  EXPECT_EQ(board_.reg16(0x8A), 2000);  // OCR1B: OUT1
  EXPECT_EQ(board_.reg16(0x88), 2500);  // OCR1A: OUT2
  EXPECT_EQ(board_.reg16(0xAC), 3000);  // OCR4C: OUT3
  EXPECT_EQ(board_.reg16(0xAA), 4000);  // OCR4B: OUT4
  EXPECT_EQ(board_.reg8(0x24) & 0x60, 0x60);   // DDRB: PB5, PB6 outputs
  EXPECT_EQ(board_.reg8(0x101) & 0x30, 0x30);  // DDRH: PH4, PH5 outputs
}

// The PPM waveform as a chain of simavr cycle timers, so each rising edge on ICP5 happens at its exact
// cycle even while the AVR sleeps (a sleeping simavr core jumps to the next timer deadline).
struct PpmSource {
  avr_irq_t* icp = nullptr;
  std::vector<avr_cycle_count_t> gaps;  // cycles before each edge
  size_t next = 0;

  static avr_cycle_count_t fire(avr_t*, avr_cycle_count_t when, void* param) {
    auto* self = static_cast<PpmSource*>(param);
    avr_raise_irq(self->icp, 0);
    avr_raise_irq(self->icp, 1);
    if (++self->next >= self->gaps.size()) return 0;
    return when + self->gaps[self->next];
  }
};

TEST_F(Apm25Drivers, PpmFramesAreDecoded) {
  // Three PPM-sum frames: a 6 ms sync gap, then eight channels; one rising edge per boundary.
  const uint16_t channels[8] = {1100, 1200, 1300, 1400, 1500, 1600, 1700, 1800};
  PpmSource ppm;
  ppm.icp = board_.icp;
  auto us = [](double v) { return static_cast<avr_cycle_count_t>(v * 16.0); };
  ppm.gaps.push_back(us(1000));
  for (int frame = 0; frame < 3; ++frame) {
    ppm.gaps.push_back(us(6000));
    for (const uint16_t c : channels) ppm.gaps.push_back(us(c));
  }
  ppm.gaps.push_back(us(6000));  // the gap after the last frame ends it
  avr_cycle_count_t total = 0;
  for (const avr_cycle_count_t g : ppm.gaps) total += g;
  avr_cycle_timer_register(board_.avr, ppm.gaps[0], &PpmSource::fire, &ppm);
  board_.run_until_cycle(board_.avr->cycle + total + us(5000));
  // Frames are published at the sync gap after them: the first gap only synchronises.
  const std::vector<uint8_t>& out = board_.uart0;
  ASSERT_GE(out.size(), 18u) << "no RC frame reported";
  size_t frames = 0;
  for (size_t i = 0; i + 18 <= out.size(); i += 18, ++frames) {
    ASSERT_EQ(out[i], 0xA5);
    ASSERT_EQ(out[i + 1], 8);
    for (int c = 0; c < 8; ++c) {
      const int us = out[i + 2 + 2 * c] | (out[i + 3 + 2 * c] << 8);
      EXPECT_NEAR(us, channels[c], 1) << "frame " << frames << " channel " << c;
    }
  }
  EXPECT_EQ(frames, 3u);
}

}  // namespace
