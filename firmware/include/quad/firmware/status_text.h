// STATUSTEXT lines assembled from flash texts, RAM strings and numbers, without printf (the freestanding
// targets have none). Anything beyond MAVLink's 50 characters is cut.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "quad/firmware/flash.h"
#include "quad/link/messages.h"

namespace quad {
namespace fw {

// One line. Out of line: one copy of each part on the AVR, not one per line assembled.
class StatusLine {
 public:
  __attribute__((noinline)) explicit StatusLine(uint8_t severity) { msg_.severity = severity; }
  __attribute__((noinline)) StatusLine& operator<<(FlashText text) {
    append_text(msg_.text, sizeof msg_.text, n_, text);
    return *this;
  }
  __attribute__((noinline)) StatusLine& operator<<(const char* ram) {
    for (const char* c = ram; c != nullptr && *c != '\0' && n_ < sizeof msg_.text; ++c) msg_.text[n_++] = *c;
    return *this;
  }
  const mavlink::Statustext& message() const { return msg_; }

 private:
  mavlink::Statustext msg_;
  size_t n_ = 0;
};

// Decimal text of an unsigned number.
class Decimal {
 public:
  explicit Decimal(uint32_t value) {
    char reversed[10];
    uint8_t n = 0;
    do {
      reversed[n++] = static_cast<char>('0' + value % 10u);
      value /= 10u;
    } while (value != 0u);
    for (uint8_t i = 0; i < n; ++i) text_[i] = reversed[n - 1 - i];
    text_[n] = '\0';
  }
  const char* c_str() const { return text_; }

 private:
  char text_[11];
};

}  // namespace fw
}  // namespace quad
