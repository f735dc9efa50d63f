// quad_link: the MAVLink v2 codec shared by the firmware, the simulator, the vision station and the
// ground tools. Freestanding (no heap, no C++ library), so it builds for the AVR and the Cortex-M too.
//
// Sending:
//   #include "quad/link/mavlink.h"
//   namespace mav = quad::mavlink;
//   mav::Sender sender(1, mav::kCompIdAutopilot1);           // one per port and component
//   mav::HilActuatorControls out;
//   out.time_usec = t; out.controls[0] = 0.5f; out.flags = mav::kHilActuatorControlsFlagLockstep;
//   uint8_t buf[mav::max_frame_length<mav::HilActuatorControls>()];
//   size_t n = sender.encode(out, buf, sizeof buf);           // 0 only if buf is too small
//   write(fd, buf, n);
//
// Receiving:
//   mav::Parser parser;                                       // one per port
//   parser.feed(data, length, [&](const mav::Frame& frame) {
//     switch (frame.message_id) {
//       case mav::HilSensor::kId: { mav::HilSensor s; if (mav::decode(frame, s)) use(s); break; }
//       ...
//     }
//   });
//   parser.stats().bad_checksum, parser.find_sender(1, 200)->lost, ...
//
// Signing (signing.h): mav::Signer fills the signature block of frames encoded with the signed flag
// (mav::encode_signed()), mav::SignatureVerifier checks received frames and rejects unsigned (when
// required), wrongly signed and replayed ones.
//
// Text fields (param_id, text): mav::copy_text(msg.param_id, "ATT_KP"), mav::text_equals(msg.param_id, "ATT_KP").
//
// See docs/mavlink.md for the wire details and what the parser counts.
#pragma once

#include "quad/link/crc.h"
#include "quad/link/enums.h"
#include "quad/link/frame.h"
#include "quad/link/messages.h"
#include "quad/link/parser.h"
#include "quad/link/sha256.h"
#include "quad/link/signing.h"
#include "quad/link/text.h"
#include "quad/link/wire.h"
