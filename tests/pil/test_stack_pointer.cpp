// The peak-stack reading of avr_pil and the board RAM test (tools/avr_pil/stack_pointer.h) on simavr's
// ATmega2560 executing avr-gcc's frame set-up, out SPH; out SREG; out SPL, for a frame that crosses a
// 256-byte page: every instruction boundary's raw SPH:SPL is recorded beside the tracked minimum.
#include <simavr/sim_avr.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "stack_pointer.h"

extern "C" const char* __asan_default_options() { return "detect_leaks=0"; }  // simavr's core allocates for good

namespace {

constexpr uint32_t kAt = 0x200;  // byte address of the sequence in flash

void put_word(avr_t* avr, uint32_t byte_address, uint16_t op) {
  avr->flash[byte_address] = static_cast<uint8_t>(op & 0xFF);
  avr->flash[byte_address + 1] = static_cast<uint8_t>(op >> 8);
}

struct Frame {
  avr_t* avr = nullptr;
  Frame(uint16_t old_sp, uint16_t new_sp) {
    avr = avr_make_mcu_by_name("atmega2560");
    avr_init(avr);
    put_word(avr, kAt, 0xBFDE);      // out 0x3e, r29 (SPH)
    put_word(avr, kAt + 2, 0xBE0F);  // out 0x3f, r0  (SREG)
    put_word(avr, kAt + 4, 0xBFCD);  // out 0x3d, r28 (SPL)
    put_word(avr, kAt + 6, 0x0000);  // nop
    put_word(avr, kAt + 8, 0x0000);  // nop
    avr->pc = kAt;
    avr->data[0x5D] = static_cast<uint8_t>(old_sp & 0xFF);
    avr->data[0x5E] = static_cast<uint8_t>(old_sp >> 8);
    avr->data[28] = static_cast<uint8_t>(new_sp & 0xFF);
    avr->data[29] = static_cast<uint8_t>(new_sp >> 8);
    avr->data[0] = 0;  // SREG to restore: interrupts off
  }
  ~Frame() { avr_terminate(avr); }
};

TEST(StackPointer, TheWindowIsTheTwoBoundariesBeforeTheSplWrite) {
  Frame f(0x2105, 0x20DD);
  const std::vector<bool> expected{false, true, true, false};  // at out SPH, out SREG, out SPL, the nop
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(parts::between_stack_pointer_writes(f.avr), expected[i]) << "instruction " << i;
    avr_run(f.avr);
  }
}

TEST(StackPointer, AFrameAcrossAPageReadsItsOwnDepthNotTheMixedPair) {
  const uint16_t old_sp = 0x2105, new_sp = 0x20DD;  // a 40-byte frame across the 0x2100 page
  Frame f(old_sp, new_sp);
  uint16_t lowest = old_sp, raw_lowest = old_sp;
  for (int i = 0; i < 4; ++i) {
    parts::track_lowest_stack_pointer(f.avr, lowest);
    raw_lowest = std::min(raw_lowest, parts::stack_pointer(f.avr));
    avr_run(f.avr);
  }
  parts::track_lowest_stack_pointer(f.avr, lowest);
  EXPECT_EQ(parts::stack_pointer(f.avr), new_sp);  // the sequence ran
  EXPECT_EQ(lowest, new_sp);
  EXPECT_EQ(raw_lowest, 0x2005);  // SPH 0x20 with the old SPL 0x05: 216 bytes too deep
}

TEST(StackPointer, AFrameWithinAPageReadsTheSameEitherWay) {
  Frame f(0x21F0, 0x21C8);
  uint16_t lowest = 0x21F0;
  for (int i = 0; i < 4; ++i) {
    parts::track_lowest_stack_pointer(f.avr, lowest);
    avr_run(f.avr);
  }
  parts::track_lowest_stack_pointer(f.avr, lowest);
  EXPECT_EQ(lowest, 0x21C8);
}

}  // namespace
