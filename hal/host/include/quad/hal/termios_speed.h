// The termios speed constant of a baud rate (Linux): one table for every host program that opens a
// serial port or a pseudo-terminal (the host HAL, the simulator's PTYs, the vision station's output).
#pragma once

#include <cstdint>

#include <termios.h>

namespace quad::hal {

// False when termios has no constant for the rate (9600 ... 4 000 000 baud, the standard steps).
inline bool termios_speed(uint32_t baud, speed_t* out) {
  static const struct {
    uint32_t baud;
    speed_t speed;
  } kTable[] = {{9600, B9600},       {19200, B19200},     {38400, B38400},     {57600, B57600},
                {115200, B115200},   {230400, B230400},   {460800, B460800},   {500000, B500000},
                {576000, B576000},   {921600, B921600},   {1000000, B1000000}, {1152000, B1152000},
                {1500000, B1500000}, {2000000, B2000000}, {2500000, B2500000}, {3000000, B3000000},
                {3500000, B3500000}, {4000000, B4000000}};
  for (const auto& entry : kTable) {
    if (entry.baud == baud) {
      *out = entry.speed;
      return true;
    }
  }
  return false;
}

}  // namespace quad::hal
