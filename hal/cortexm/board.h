// What a Cortex-M board file provides to the board-independent part (hal_cortexm.cpp: SysTick clock,
// idle, hal::init). QEMU's mps2-an386 is mps2_an386.cpp; a real board (e.g. an STM32F4) is another
// file implementing these, plus its linker script.
#pragma once

#include <stdint.h>

#include "quad/hal/hal.h"

namespace quad {
namespace hal {
namespace cortexm {

extern const uint32_t kCoreClockHz;  // SysTick counts this clock

void board_init();       // UARTs, LED, interrupt controller; called by hal::init() with interrupts off
bool board_rx_pending();  // a received byte waits in a ring

}  // namespace cortexm
}  // namespace hal
}  // namespace quad
