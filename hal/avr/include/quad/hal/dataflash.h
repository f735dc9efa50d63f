// The APM 2.5's DataFlash (Atmel AT45DB321D, 4 MB) as the board's flight-log store: the functions of a
// quad::fw::LogStore (firmware/include/quad/firmware/log_store.h; the context is unused), which the
// image assembles, so the HAL needs nothing of the firmware. Layout, index and timing: docs/logging.md.
//
// Non-blocking in flight: append() writes into one of the chip's two SRAM buffers while the other is
// programmed into its page (about 17 ms), and takes fewer bytes when both are in use; read() and entry()
// answer 0 / false while a page is being programmed (the caller asks again later). The data pages are a
// ring: open() never refuses for lack of room; a log that reaches the oldest log's first page drops that
// log (its ids shift down by one), and a 65th log drops the oldest. A log that comes round to its own
// first page (the chip holds nothing else) ends there: append() takes nothing more, its beginning (the
// ULog definitions) is kept, and the next log drops it. close() and erase_all() (once per log, on the
// ground) wait for the page being programmed, at most one page program time (tEP, 40 ms), so the log's
// last page is in the flash when close() returns; erase_all() forgets every log.
#pragma once

#include <stdint.h>

namespace quad {
namespace hal {
namespace avr {

// Brings up USART3 as the SPI master and reads the log index; false when no AT45DB321D in 528-byte page
// mode answers (every other call then reports no logs and refuses to open one).
bool dataflash_start();

bool dataflash_open(void* context, uint32_t time_utc_s);
uint16_t dataflash_append(void* context, const uint8_t* data, uint16_t length);
void dataflash_close(void* context);
uint16_t dataflash_count(void* context);
// Fills size_bytes and time_utc_s (a LogEntry's two fields, in that order).
bool dataflash_entry(void* context, uint16_t id, uint32_t* size_bytes, uint32_t* time_utc_s);
uint16_t dataflash_read(void* context, uint16_t id, uint32_t offset, uint8_t* dst, uint16_t length);
bool dataflash_erase_all(void* context);

}  // namespace avr
}  // namespace hal
}  // namespace quad
