// Board-independent part of the Cortex-M HAL: hal::init(), the microsecond clock from SysTick (every
// Cortex-M has one) and idle() as WFI. The board file (board.h) supplies the clock frequency, UARTs,
// storage and LED.
#include <stdint.h>

#include "board.h"
#include "quad/hal/hal.h"

namespace {

// SysTick and SCB registers (ARMv7-M architecture reference manual, B3.3 and B3.2).
volatile uint32_t& kSystCsr = *reinterpret_cast<volatile uint32_t*>(0xE000E010u);
volatile uint32_t& kSystRvr = *reinterpret_cast<volatile uint32_t*>(0xE000E014u);
volatile uint32_t& kSystCvr = *reinterpret_cast<volatile uint32_t*>(0xE000E018u);
volatile uint32_t& kScbIcsr = *reinterpret_cast<volatile uint32_t*>(0xE000ED04u);
constexpr uint32_t kCsrEnable = 1u << 0, kCsrTickInt = 1u << 1, kCsrCoreClock = 1u << 2;
constexpr uint32_t kIcsrPendStSet = 1u << 26;

volatile uint32_t g_millis = 0;
uint32_t g_ticks_per_us = 1;

uint32_t disable_irq() {
  uint32_t primask;
  __asm volatile("mrs %0, primask\n cpsid i" : "=r"(primask)::"memory");
  return primask;
}
void restore_irq(uint32_t primask) { __asm volatile("msr primask, %0" ::"r"(primask) : "memory"); }

}  // namespace

extern "C" void SysTick_Handler() { g_millis = g_millis + 1u; }

namespace quad {
namespace hal {

void init() {
  const uint32_t primask = disable_irq();
  g_ticks_per_us = cortexm::kCoreClockHz / 1000000u;
  kSystRvr = cortexm::kCoreClockHz / 1000u - 1u;  // one interrupt per millisecond
  kSystCvr = 0;
  kSystCsr = kCsrEnable | kCsrTickInt | kCsrCoreClock;
  cortexm::board_init();
  restore_irq(primask);
  __asm volatile("cpsie i" ::: "memory");
}

uint32_t micros() {
  const uint32_t primask = disable_irq();
  uint32_t ms = g_millis;
  uint32_t value = kSystCvr;
  // A wrap not yet counted by the handler (pending): the counter restarted, read it again.
  if (kScbIcsr & kIcsrPendStSet) {
    value = kSystCvr;
    ++ms;
  }
  restore_irq(primask);
  return ms * 1000u + (kSystRvr - value) / g_ticks_per_us;
}

void idle(uint32_t max_wait_us) {
  // WFI wakes on any interrupt, the SysTick every millisecond at the latest. With interrupts masked,
  // a pending interrupt still ends WFI, so a byte arriving between the check and the WFI is not missed.
  const uint32_t start = micros();
  for (;;) {
    const uint32_t primask = disable_irq();
    const bool done = cortexm::board_rx_pending() || micros() - start >= max_wait_us;
    if (!done) __asm volatile("wfi" ::: "memory");
    restore_irq(primask);
    if (done) return;
  }
}

}  // namespace hal
}  // namespace quad
