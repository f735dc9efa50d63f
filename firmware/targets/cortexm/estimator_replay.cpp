// Estimator replay on the Cortex-M4F (tests/pil/test_estimator_agreement.cpp): the recorded sensor log
// through the observer and the position filter, the estimates out on UART0 (polled), then exit through
// semihosting (QEMU's -semihosting).
#include <stdint.h>

#include "replay_core.h"

namespace {

const quad::replay::Row kLog[] = {
#include "recorded_log.inc"
};

volatile uint32_t* const kUart0 = reinterpret_cast<volatile uint32_t*>(0x40004000u);

void put(char c) {
  while (kUart0[1] & 1u) {  // STATE.TX full
  }
  kUart0[0] = static_cast<uint8_t>(c);
}

}  // namespace

int main() {
  kUart0[4] = 16u;  // BAUDDIV: the smallest legal divider
  kUart0[2] = 1u;   // CTRL: transmitter on
  quad::replay::run(
      sizeof kLog / sizeof kLog[0], [](uint16_t i, quad::replay::Row& row) { row = kLog[i]; }, put);
  // SYS_EXIT (0x18) with ADP_Stopped_ApplicationExit.
  __asm volatile("mov r0, #0x18\n ldr r1, =0x20026\n bkpt 0xAB" ::: "r0", "r1", "memory");
  for (;;) {
  }
}
