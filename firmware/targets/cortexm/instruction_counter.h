// The instruction-count harness of the Cortex-M4F benchmark images on QEMU's mps2-an386 with
// `-icount shift=0` (instruction_count.cpp, ekf_instruction_count.cpp; docs/targets.md).
//
// Method: with -icount shift=0 QEMU advances its virtual clock by exactly 1 ns per executed guest
// instruction, and SysTick counts that clock at the board's 25 MHz: one tick per 40 instructions.
// SysTick runs free from its 24-bit reload with its interrupt off, and a section's count is its tick
// difference times 40. Two calibration loops of known instruction counts check the method on every
// run. Means over many iterations resolve below one tick; a single iteration is known to +-40
// instructions. Results go to UART0 as "name instructions" lines; the image exits through semihosting.
// Included once by each image's single source file.
#pragma once

#include <stdint.h>

namespace {

// ---- measurement --------------------------------------------------------------------------------
volatile uint32_t& kSystCsr = *reinterpret_cast<volatile uint32_t*>(0xE000E010u);
volatile uint32_t& kSystRvr = *reinterpret_cast<volatile uint32_t*>(0xE000E014u);
volatile uint32_t& kSystCvr = *reinterpret_cast<volatile uint32_t*>(0xE000E018u);
constexpr uint32_t kInstructionsPerTick = 40;  // 25 MHz SysTick, 1 ns per instruction

void start_counter() {
  kSystRvr = 0x00FFFFFFu;
  kSystCvr = 0;
  kSystCsr = (1u << 2) | 1u;  // core clock, enabled, no interrupt
}
// SysTick counts down; sections stay far below one 24-bit period (16.7 M ticks).
uint32_t ticks_between(uint32_t start, uint32_t end) { return (start - end) & 0x00FFFFFFu; }

template <typename T>
void keep(const T& value) {
  __asm volatile("" : : "r"(&value) : "memory");
}

// ---- output (polled CMSDK UART0; the HAL is not needed here) -------------------------------------
volatile uint32_t* const kUart0 = reinterpret_cast<volatile uint32_t*>(0x40004000u);

void put(char c) {
  while (kUart0[1] & 1u) {
  }
  kUart0[0] = static_cast<uint8_t>(c);
}
void put(const char* s) {
  while (*s) put(*s++);
}
void put_number(uint32_t v) {
  char digits[10];
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + v % 10u);
    v /= 10u;
  } while (v != 0);
  while (n > 0) put(digits[--n]);
}

// Runs `f` `repeat` times and reports the mean instruction count per run, the loop's own two or three
// instructions per run included (reported as loop_overhead).
template <typename F>
void measure(const char* name, uint32_t repeat, F&& f) {
  const uint32_t start = kSystCvr;
  for (uint32_t i = 0; i < repeat; ++i) f();
  const uint32_t ticks = ticks_between(start, kSystCvr);
  put(name);
  put(' ');
  put_number((ticks * kInstructionsPerTick + repeat / 2u) / repeat);
  put('\n');
}

void calibrate(const char* name, uint32_t passes) {
  const uint32_t start = kSystCvr;
  uint32_t n = passes;
  __asm volatile("1: nop\n nop\n subs %0, %0, #1\n bne 1b" : "+r"(n) : : "cc");
  const uint32_t ticks = ticks_between(start, kSystCvr);
  put(name);
  put(' ');
  put_number(ticks * kInstructionsPerTick);
  put('\n');
}

// UART0 on, SysTick running, and the method checked: n passes of a 4-instruction loop body (nop, nop,
// subs, bne) = 4 n instructions, at two lengths so a fixed offset of the reads shows apart from the slope.
void start_and_calibrate() {
  kUart0[4] = 16u;  // BAUDDIV: the smallest legal divider
  kUart0[2] = 1u;   // CTRL: transmitter on
  start_counter();
  calibrate("calibration_4000", 1000);
  calibrate("calibration_40000", 10000);
}

void semihosting_exit() {
  // SYS_EXIT (0x18) with ADP_Stopped_ApplicationExit.
  __asm volatile("mov r0, #0x18\n ldr r1, =0x20026\n bkpt 0xAB" ::: "r0", "r1", "memory");
}

}  // namespace
