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

// A NUL-terminated text in flash: the status messages and names the application reports. The type
// keeps flash pointers apart from RAM pointers, which the AVR cannot mix up.
struct FlashText {
  const char* p;
};

#if defined(__AVR__)
// Each text lives in its own lambda: avr-g++ 5.4 loses the names of several PSTR() statics in one
// function (undefined references to `__c` at link time).
#define QUAD_TEXT(s) \
  (::quad::fw::FlashText{[]() -> const char* { static const char text[] PROGMEM = s; return text; }()})
#else
#define QUAD_TEXT(s) (::quad::fw::FlashText{s})
#endif

inline char flash_char(const char* p) {
#if defined(__AVR__)
  return static_cast<char>(pgm_read_byte(p));
#else
  return *p;
#endif
}

// Appends `text` to dst[n .. capacity), advancing n; stops at the capacity (no terminator added).
inline void append_text(char* dst, size_t capacity, size_t& n, FlashText text) {
  for (const char* s = text.p; n < capacity; ++s) {
    const char c = flash_char(s);
    if (c == '\0') break;
    dst[n++] = c;
  }
}

}  // namespace fw
}  // namespace quad
