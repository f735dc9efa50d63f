// MAVLink char-array fields (param_id[16], text[50]): NUL-padded, and not NUL-terminated when full.
// These helpers write and compare them without ever reading past the field or the C string.
#pragma once

#include <stddef.h>

namespace quad {
namespace mavlink {

// Copies `text` into the field, truncated to N characters, and pads the rest with NUL. Returns false when
// `text` was longer than the field (it is then truncated).
template <size_t N>
bool copy_text(char (&field)[N], const char* text) {
  size_t i = 0;
  for (; i < N && text[i] != '\0'; ++i) field[i] = text[i];
  const bool fits = text[i] == '\0';
  for (; i < N; ++i) field[i] = '\0';
  return fits;
}

// The length of the field's text: up to the first NUL, or N when the field is full.
template <size_t N>
size_t text_length(const char (&field)[N]) {
  size_t length = 0;
  while (length < N && field[length] != '\0') ++length;
  return length;
}

// True when the field holds exactly `text` (a name of N characters matches a full, unterminated field).
template <size_t N>
bool text_equals(const char (&field)[N], const char* text) {
  size_t i = 0;
  for (; i < N && field[i] != '\0'; ++i) {
    if (text[i] != field[i]) return false;
  }
  return text[i] == '\0';
}

}  // namespace mavlink
}  // namespace quad
