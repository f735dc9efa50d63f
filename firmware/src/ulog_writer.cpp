#include "quad/firmware/ulog_writer.h"

#include "quad/firmware/status_text.h"

namespace quad {
namespace fw {

namespace {

// The longest key and short value composed in RAM (info and parameter keys are short).
constexpr uint8_t kKeyCapacity = 48;

// Appends text to p[n .. kKeyCapacity); returns the new length.
uint8_t put_text(uint8_t* p, uint8_t n, FlashText text) {
  size_t at = n;
  append_text(reinterpret_cast<char*>(p), kKeyCapacity, at, text);
  return static_cast<uint8_t>(at);
}

uint8_t put_ram(uint8_t* p, uint8_t n, const char* text) {
  while (*text != '\0' && n < kKeyCapacity) p[n++] = static_cast<uint8_t>(*text++);
  return n;
}

}  // namespace

UlogFields& UlogFields::u8(uint8_t v) { return bytes(&v, 1); }
UlogFields& UlogFields::u32(uint32_t v) { return bytes(&v, sizeof v); }
UlogFields& UlogFields::u64(uint64_t v) { return bytes(&v, sizeof v); }
UlogFields& UlogFields::f32(float v) { return bytes(&v, sizeof v); }
UlogFields& UlogFields::f32(const float* v, uint8_t n) { return bytes(v, static_cast<uint8_t>(n * sizeof(float))); }
UlogFields& UlogFields::bytes(const void* v, uint8_t n) {
  memcpy(p_, v, n);
  p_ += n;
  return *this;
}

uint16_t flash_length(FlashText text) {
  uint16_t n = 0;
  while (flash_char(text.p + n) != '\0') ++n;
  return n;
}

bool UlogWriter::open(uint64_t timestamp_us, uint32_t time_utc_s) {
  if (open_) close();
  if (!has_store() || !store_->open(store_->context, time_utc_s)) return false;
  open_ = true;
  head_ = tail_ = 0;
  flash_left_ = 0;
  // File header: magic "ULog" 0x01 0x12 0x35, version 1, the timestamp; then the flag bits (all zero: no
  // compatible or incompatible flags, no appended data), which must be the first message.
  static const uint8_t kMagic[8] QUAD_FLASH = {'U', 'L', 'o', 'g', 0x01, 0x12, 0x35, 0x01};
  flash_copy(buffer_, kMagic, sizeof kMagic);
  memcpy(buffer_ + 8, &timestamp_us, sizeof timestamp_us);
  uint8_t* flags = buffer_ + ulog::kFileHeaderBytes;
  flags[0] = ulog::kFlagBitsPayload;
  flags[1] = 0;
  flags[2] = ulog::kFlagBits;
  memset(flags + ulog::kMessageHeaderBytes, 0, ulog::kFlagBitsPayload);
  tail_ = ulog::kFileHeaderBytes + ulog::kMessageHeaderBytes + ulog::kFlagBitsPayload;
  flush();
  return true;
}

void UlogWriter::close() {
  if (!open_) return;
  // The queued records may be several: a store busy for a few calls gets more, so that the log does not
  // end in the middle of a record; what it still has not taken is lost.
  uint8_t attempts = kCloseAttempts;
  while (!flush() && --attempts != 0) {
  }
  if (attempts == 0) ++dropped_;
  if (store_->close != nullptr) store_->close(store_->context);
  open_ = false;
  head_ = tail_ = 0;
  flash_left_ = 0;
}

bool UlogWriter::flush(uint16_t max_bytes) {
  while (open_) {
    if (head_ == tail_) {
      head_ = tail_ = 0;
      if (flash_left_ == 0) return true;
      const uint16_t n = flash_left_ < kStagingBytes ? flash_left_ : kStagingBytes;
      flash_copy(buffer_, flash_rest_, n);
      flash_rest_ += n;
      flash_left_ = static_cast<uint16_t>(flash_left_ - n);
      tail_ = n;
    }
    if (max_bytes == 0) return false;
    const uint16_t pending = static_cast<uint16_t>(tail_ - head_);
    const uint16_t want = pending < max_bytes ? pending : max_bytes;
    const uint16_t took = store_->append(store_->context, buffer_ + head_, want);
    const uint16_t taken = took < want ? took : want;
    head_ = static_cast<uint16_t>(head_ + taken);
    max_bytes = static_cast<uint16_t>(max_bytes - taken);
    if (took < want) return false;
  }
  return true;
}

void UlogWriter::compact() {
  memmove(buffer_, buffer_ + head_, tail_ - head_);
  tail_ = static_cast<uint16_t>(tail_ - head_);
  head_ = 0;
}

bool UlogWriter::dropout(uint16_t duration_ms) {
  uint8_t* p = reserve(ulog::kDropout, sizeof duration_ms, sizeof duration_ms);
  if (p == nullptr) return false;
  memcpy(p, &duration_ms, sizeof duration_ms);
  return true;
}

uint8_t* UlogWriter::reserve(uint8_t type, uint16_t payload, uint8_t in_buffer) {
  if (!open_) return nullptr;
  const uint16_t need = static_cast<uint16_t>(ulog::kMessageHeaderBytes + in_buffer);
  // The queued records wait for the next flush() (one append for several records, about 600 cycles a
  // call on the ATmega2560's DataFlash, in an iteration with time for it), or go when the next one needs
  // their room. A format's text goes first.
  if (flash_left_ != 0) flush();
  if (flash_left_ == 0 && kStagingBytes - tail_ < need) {
    if (kStagingBytes - pending() < need) {
      // Full: the store takes what the iteration has time for, once (the limit counts down), and the
      // pending bytes move to the front once.
      const uint16_t before = pending();
      flush(room_flush_limit_);
      const uint16_t sent = static_cast<uint16_t>(before - pending());
      if (room_flush_limit_ != 0xFFFFu) room_flush_limit_ = static_cast<uint16_t>(room_flush_limit_ - sent);
    }
    if (head_ > 0) compact();
  }
  if (flash_left_ != 0 || kStagingBytes - tail_ < need) {
    ++dropped_;
    return nullptr;
  }
  uint8_t* p = buffer_ + tail_;
  p[0] = static_cast<uint8_t>(payload & 0xFFu);
  p[1] = static_cast<uint8_t>(payload >> 8);
  p[2] = type;
  tail_ = static_cast<uint16_t>(tail_ + need);
  return p + ulog::kMessageHeaderBytes;
}

bool UlogWriter::format(FlashText text) { return format(text, flash_length(text)); }

bool UlogWriter::format(FlashText text, uint16_t length) {
  // The header alone goes in the buffer; the text follows from flash as the store drains it.
  if (reserve(ulog::kFormat, length, 0) == nullptr) return false;
  flash_rest_ = text.p;
  flash_left_ = length;
  flush();
  return true;
}

bool UlogWriter::add_logged(uint16_t msg_id, FlashText format) {
  uint8_t name[kKeyCapacity];
  uint8_t n = 0;
  while (n < kKeyCapacity) {
    const char c = flash_char(format.p + n);
    if (c == ':' || c == '\0') break;
    name[n++] = static_cast<uint8_t>(c);
  }
  uint8_t* p = reserve(ulog::kAddLogged, static_cast<uint16_t>(3 + n), static_cast<uint8_t>(3 + n));
  if (p == nullptr) return false;
  p[0] = 0;  // multi_id
  p[1] = static_cast<uint8_t>(msg_id & 0xFFu);
  p[2] = static_cast<uint8_t>(msg_id >> 8);
  memcpy(p + 3, name, n);
  return true;
}

bool UlogWriter::info(FlashText name, FlashText value) {
  uint8_t key[kKeyCapacity];
  const uint16_t value_length = flash_length(value);
  const Decimal digits(value_length);
  uint8_t n = put_text(key, 0, QUAD_TEXT("char["));
  n = put_ram(key, n, digits.c_str());
  n = put_text(key, n, QUAD_TEXT("] "));
  n = put_text(key, n, name);
  if (value_length > kKeyCapacity) return false;
  const uint8_t payload = static_cast<uint8_t>(1 + n + value_length);
  uint8_t* p = reserve(ulog::kInfo, payload, payload);
  if (p == nullptr) return false;
  p[0] = n;
  memcpy(p + 1, key, n);
  flash_copy(p + 1 + n, value.p, value_length);
  return true;
}

bool UlogWriter::key_value(uint8_t type, const uint8_t* key, uint8_t key_length, const void* value, uint8_t size) {
  const uint8_t payload = static_cast<uint8_t>(1 + key_length + size);
  uint8_t* p = reserve(type, payload, payload);
  if (p == nullptr) return false;
  p[0] = key_length;
  memcpy(p + 1, key, key_length);
  memcpy(p + 1 + key_length, value, size);
  return true;
}

bool UlogWriter::info(FlashText name, uint32_t value) {
  uint8_t key[kKeyCapacity];
  uint8_t n = put_text(key, 0, QUAD_TEXT("uint32_t "));
  n = put_text(key, n, name);
  return key_value(ulog::kInfo, key, n, &value, sizeof value);
}

bool UlogWriter::parameter(const char* name, float value) {
  uint8_t key[kKeyCapacity];
  uint8_t n = put_text(key, 0, QUAD_TEXT("float "));
  n = put_ram(key, n, name);
  return key_value(ulog::kParameter, key, n, &value, sizeof value);
}

bool UlogWriter::logged_string(uint8_t level, uint64_t timestamp_us, const char* text, uint8_t length) {
  const uint8_t payload = static_cast<uint8_t>(1 + sizeof timestamp_us + length);
  uint8_t* p = reserve(ulog::kLogging, payload, payload);
  if (p == nullptr) return false;
  UlogFields(p).u8(level).u64(timestamp_us).bytes(text, length);
  return true;
}

uint8_t* UlogWriter::begin_data(uint16_t msg_id, uint8_t size) {
  uint8_t* p = reserve(ulog::kData, static_cast<uint16_t>(2 + size), static_cast<uint8_t>(2 + size));
  if (p == nullptr) return nullptr;
  p[0] = static_cast<uint8_t>(msg_id & 0xFFu);
  p[1] = static_cast<uint8_t>(msg_id >> 8);
  return p + 2;
}

}  // namespace fw
}  // namespace quad
