// Parameter storage in the ATmega2560's 4 KiB EEPROM. Writes go through eeprom_update_block(), which
// skips bytes that already hold the value (an EEPROM cell survives about 100 000 erase/write cycles).
#include <avr/eeprom.h>

#include "quad/hal/hal.h"

namespace quad {
namespace hal {

namespace {
constexpr uint16_t kEepromSize = E2END + 1;
bool in_range(uint16_t offset, uint16_t length) { return static_cast<uint32_t>(offset) + length <= kEepromSize; }
}  // namespace

uint16_t storage_size() { return kEepromSize; }

bool storage_read(uint16_t offset, void* dst, uint16_t length) {
  if (!in_range(offset, length)) return false;
  eeprom_read_block(dst, reinterpret_cast<const void*>(offset), length);
  return true;
}

bool storage_write(uint16_t offset, const void* src, uint16_t length) {
  if (!in_range(offset, length)) return false;
  eeprom_update_block(src, reinterpret_cast<void*>(offset), length);
  return true;
}

}  // namespace hal
}  // namespace quad
