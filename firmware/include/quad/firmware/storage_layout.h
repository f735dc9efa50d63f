// Where each record lives in the persistent storage (the ATmega2560's 4 KiB EEPROM, a file of the same
// size on the host). Every record is redundant (redundant_record.h): two copies, so its footprint is
// twice the payload plus the overhead.
#pragma once

#include <stdint.h>

#include "quad/firmware/params.h"
#include "quad/firmware/redundant_record.h"

namespace quad {
namespace fw {

constexpr uint16_t kSigningKeyPayload = 32;  // the MAVLink signing secret key
constexpr uint16_t kSigningClockPayload = 8; // the signing timestamp (48 bits used), little-endian

constexpr uint16_t kParamsStoreOffset = 0;
constexpr uint16_t kSigningKeyOffset = kParamsStoreOffset + record_footprint(kParamCount * sizeof(float));
constexpr uint16_t kSigningClockOffset = kSigningKeyOffset + record_footprint(kSigningKeyPayload);
constexpr uint16_t kStorageUsed = kSigningClockOffset + record_footprint(kSigningClockPayload);

constexpr uint16_t kEepromSize = 4096;  // ATmega2560
static_assert(kStorageUsed <= kEepromSize, "the records must fit the AVR's EEPROM");

}  // namespace fw
}  // namespace quad
