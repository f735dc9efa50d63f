// Cycle probes for code running on the simulated ATmega2560 under tools/avr_cycles.
//
// The probes write to the general-purpose I/O registers, which the host watches: GPIOR2 takes the
// characters of a section name, GPIOR0 takes a command (1 start, 2 stop, 0xFF done). Each probe is a
// single `out` instruction (1 cycle); the host subtracts the cost of an empty section ("overhead").
#pragma once

#include <avr/io.h>

namespace quad_probe {

inline void name(const char* s) {
  while (*s) GPIOR2 = static_cast<uint8_t>(*s++);
}
inline void start() { GPIOR0 = 1; }
inline void stop() { GPIOR0 = 2; }
inline void done() { GPIOR0 = 0xFF; }

// Keeps the compiler from folding a benchmarked computation away.
template <typename T>
inline void keep(const T& value) {
  __asm__ __volatile__("" : : "r"(&value) : "memory");
}

// One named section around f().
template <typename F>
inline void measure(const char* section, F&& f) {
  name(section);
  start();
  f();
  stop();
}

// A zero-length section whose name reports a failed scenario check (read by check_cycle_budget.cmake).
inline void check(bool ok, const char* what) {
  if (ok) return;
  name("check_failed:");
  name(what);
  start();
  stop();
}

}  // namespace quad_probe
