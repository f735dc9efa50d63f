// Constant tables that should live in flash only.
//
// On the AVR (Harvard architecture) a plain `const` table is copied into the 8 KiB SRAM at start-up;
// QUAD_FLASH places it in program memory instead, and flash_copy() reads it back. Elsewhere flash and
// RAM share one address space and both are ordinary memcpy.
#pragma once

#include <stddef.h>
#include <string.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>
#define QUAD_FLASH PROGMEM
#else
#define QUAD_FLASH
#endif

namespace quad {
namespace fw {

inline void flash_copy(void* dst, const void* src_in_flash, size_t n) {
#if defined(__AVR__)
  memcpy_P(dst, src_in_flash, n);
#else
  memcpy(dst, src_in_flash, n);
#endif
}

}  // namespace fw
}  // namespace quad
