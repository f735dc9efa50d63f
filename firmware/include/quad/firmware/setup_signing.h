// SETUP_SIGNING (MAVLink common, id 256): provisions the signing key. The flight code's own message,
// written in the codec's style (quad/link/messages.h) rather than added to the shared codec, because only
// the vehicle and the ground station speak it; firmware_message_info() extends the codec's table with it
// for the parsers that must recognise it. Id, CRC_EXTRA and layout are those of node-mavlink 2.3's
// mavlink-mappings (SetupSigning: MSG_ID 256, MAGIC_NUMBER 71, PAYLOAD_LENGTH 42), checked against
// node-mavlink in tests/firmware/test_signing.cpp.
#pragma once

#include <stdint.h>

#include "quad/link/frame.h"
#include "quad/link/wire.h"

namespace quad {
namespace fw {

// An all-zero key with initial_timestamp 0 turns signing off (MAVLink's definition).
struct SetupSigning {
  static constexpr uint32_t kId = 256;
  static constexpr uint8_t kCrcExtra = 71;
  static constexpr uint8_t kBaseLength = 42;
  static constexpr uint8_t kLength = 42;
  static constexpr const char* kName = "SETUP_SIGNING";
  uint64_t initial_timestamp = 0;  // the signing timestamp to start from (10 us since 2015-01-01)
  uint8_t target_system = 0;
  uint8_t target_component = 0;
  uint8_t secret_key[32] = {};
  template <class M, class Io>
  static constexpr void fields(M& m, Io& io) {
    io(m.initial_timestamp); io(m.target_system); io(m.target_component); io(m.secret_key);
  }
};
static_assert(mavlink::wire::count_fields<SetupSigning>().length == SetupSigning::kLength, "SETUP_SIGNING layout");

// The codec's messages plus SETUP_SIGNING.
inline bool firmware_message_info(uint32_t message_id, mavlink::MessageInfo* info) {
  if (message_id == SetupSigning::kId) {
    *info = mavlink::message_info<SetupSigning>();
    return true;
  }
  return mavlink::find_message_info(message_id, info);
}

}  // namespace fw
}  // namespace quad
