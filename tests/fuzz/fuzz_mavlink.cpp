// Fuzz target: the MAVLink v2 streaming parser and every message decoder.
//
// Properties checked on every input, beyond "no crash, no out-of-bounds access" (the sanitizers):
// - byte accounting: every pushed byte is in an accepted frame, discarded, or still held;
// - an accepted frame decodes into its message, and re-encoding the decoded message with the same header
//   gives a frame the parser accepts again with the same payload (zero-extended to the full length).
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "quad/link/mavlink.h"

namespace {

namespace mv = quad::mavlink;

[[noreturn]] void fail(const char* what) {
  __builtin_printf("fuzz_mavlink: property violated: %s\n", what);
  abort();
}

template <class Msg>
void round_trip(const mv::Frame& frame) {
  Msg msg;
  if (frame.message_id != Msg::kId) return;
  if (!mv::decode(frame, msg)) fail("accepted frame does not decode into its message");
  mv::FrameHeader header;
  header.system_id = frame.system_id;
  header.component_id = frame.component_id;
  header.sequence = frame.sequence;
  header.compat_flags = frame.compat_flags;
  uint8_t out[mv::kMaxFrameLength];
  const size_t n = mv::encode(msg, header, out, sizeof out);
  if (n == 0) fail("decoded message does not encode");
  mv::Parser again;
  int frames = 0;
  uint8_t original[mv::kMaxPayloadLength] = {};
  uint8_t reencoded[mv::kMaxPayloadLength] = {};
  memcpy(original, frame.payload, frame.payload_length);
  again.feed(out, n, [&](const mv::Frame& f) {
    ++frames;
    if (f.message_id != Msg::kId) fail("re-encoded frame has another message id");
    memcpy(reencoded, f.payload, f.payload_length);
  });
  if (frames != 1) fail("re-encoded frame not accepted exactly once");
  if (memcmp(original, reencoded, Msg::kLength) != 0) fail("payload changed in a decode/encode round trip");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  mv::Parser parser;
  size_t accepted_bytes = 0;
  parser.feed(data, size, [&](const mv::Frame& frame) {
    accepted_bytes += frame.size;
    mv::for_each_message_type([&](auto tag) { round_trip<decltype(tag)>(frame); });
  });
  const mv::ParserStats& s = parser.stats();
  if (accepted_bytes + s.bytes_discarded + parser.held_bytes() != size) fail("byte accounting");
  return 0;
}
