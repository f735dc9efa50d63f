// The ATmega2560's stack pointer on simavr, read as a stack depth (avr_pil's peak stack, the board
// image's RAM test).
#pragma once

#include <simavr/sim_avr.h>

#include <cstdint>

namespace parts {

// SPL and SPH, data addresses 0x5D and 0x5E.
inline uint16_t stack_pointer(const avr_t* avr) {
  return static_cast<uint16_t>(avr->data[0x5D] | (avr->data[0x5E] << 8));
}

// True when the instruction at the program counter, or the one after it, is `out 0x3d, Rr` (a write of
// SPL). avr-gcc moves the stack pointer to a new frame as out SPH; out SREG; out SPL with interrupts held
// off, so at those two instruction boundaries SPH holds the new frame's byte and SPL the old one: a pair
// that reads up to 255 bytes below the real pointer when the frame crosses a 256-byte page.
inline bool between_stack_pointer_writes(const avr_t* avr) {
  auto writes_spl = [avr](uint32_t byte_address) {
    if (byte_address + 1 > avr->flashend) return false;
    const uint16_t op = static_cast<uint16_t>(avr->flash[byte_address] | (avr->flash[byte_address + 1] << 8));
    return (op & 0xFE0F) == 0xBE0D;  // OUT A, Rr is 1011 1AAr rrrr AAAA; A = 0x3d = 11 1101
  };
  return writes_spl(avr->pc) || writes_spl(avr->pc + 2);
}

// Lowers `lowest` to the stack pointer, except between the two writes of a frame's pointer.
inline void track_lowest_stack_pointer(const avr_t* avr, uint16_t& lowest) {
  if (between_stack_pointer_writes(avr)) return;
  const uint16_t sp = stack_pointer(avr);
  if (sp < lowest) lowest = sp;
}

}  // namespace parts
