// Host target of the HAL (Linux): serial ports by path in termios raw mode (a pseudo-terminal from
// the simulator or a USB serial adapter), a monotonic microsecond clock, and the parameter storage
// kept in a file. The host has no sensors or motors of its own: it runs HIL images only.
#pragma once

#include <stdint.h>

#include <string>

#include "quad/hal/hal.h"

namespace quad {
namespace hal {
namespace host {

struct PortConfig {
  std::string path;   // empty: the port is not connected (reads nothing, writes are dropped)
  uint32_t baud = 0;  // one of the standard termios rates (9600 ... 4000000)
};

// The ATmega2560 has 4 KiB of EEPROM; the host offers the same so a store that fits here fits there.
constexpr uint16_t kStorageSize = 4096;

struct Config {
  PortConfig ports[kPortCount];
  std::string storage_path;  // empty: storage lives in memory only and starts erased (0xFF)
};

// Opens the ports and the storage file. On failure returns false and says what failed (the path
// and the system's reason) in `error`; nothing stays open.
bool open(const Config& config, std::string* error);

// Closes everything opened by open().
void close();

// True once the peer of a port went away (pseudo-terminal master closed, adapter unplugged).
bool port_hung_up(Port port);

// Bytes a port dropped because the peer did not read fast enough (writes never block).
uint32_t bytes_dropped(Port port);

// The status LED as last written (the host has none to light).
bool led_state();

// Maps a baud rate to its termios constant; false when the rate is not a standard one.
bool baud_supported(uint32_t baud);

}  // namespace host
}  // namespace hal
}  // namespace quad
