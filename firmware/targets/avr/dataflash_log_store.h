// The APM 2.5 images' LogStore: the DataFlash driver's functions (hal/avr/dataflash.cpp).
#pragma once

#include "quad/firmware/log_store.h"
#include "quad/hal/dataflash.h"

namespace quad {
namespace fw {

inline bool dataflash_entry(void* context, uint16_t id, LogEntry* out) {
  return hal::avr::dataflash_entry(context, id, &out->size_bytes, &out->time_utc_s);
}

constexpr LogStore kDataflashLogStore = {
    nullptr,
    hal::avr::dataflash_open,
    hal::avr::dataflash_append,
    hal::avr::dataflash_close,
    hal::avr::dataflash_count,
    dataflash_entry,
    hal::avr::dataflash_read,
    hal::avr::dataflash_erase_all,
};

}  // namespace fw
}  // namespace quad
