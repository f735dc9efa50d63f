// The wire between the simulator's rendered cameras and the station's `sim:ENDPOINT` source: a Unix
// stream socket at ENDPOINT (the simulator listens, the station connects). Native byte order, both ends
// on the same host. Documented in docs/vision_station.md ("The sim: source").
//
//   simulator -> station, per captured pair:  FrameHeader, then width*height bytes left, then right (8-bit grey)
//   station -> simulator, per pair, after its output for that pair has been written to its radio port:
//                                              FrameAnswer
// The simulator closes the socket at the end of the run; the source then reports the end of frames.
#pragma once

#include <cstdint>

namespace quad::vision::sim_protocol {

inline constexpr uint32_t kFrameMagic = 0x51534D46;   // "QSMF"
inline constexpr uint32_t kAnswerMagic = 0x51534D41;  // "QSMA"

struct FrameHeader {
  uint32_t magic = kFrameMagic;
  uint32_t width = 0, height = 0;
  uint32_t reserved = 0;
  uint64_t sequence = 0;         // counts captured pairs from 0 (lost frames leave gaps)
  int64_t capture_time_us = 0;   // simulated time = the vehicle's HIL clock
};

struct FrameAnswer {
  uint32_t magic = kAnswerMagic;
  uint32_t fix_found = 0;        // 1 when the star was located in this pair
  uint64_t sequence = 0;         // the pair answered
  uint64_t fixes_sent = 0;       // LANDING_TARGET frames written to the radio port so far (all pairs)
  double processing_us = 0.0;    // the station's measured wall-clock processing time of this pair
};

static_assert(sizeof(FrameHeader) == 32 && sizeof(FrameAnswer) == 32, "fixed wire layout");

}  // namespace quad::vision::sim_protocol
