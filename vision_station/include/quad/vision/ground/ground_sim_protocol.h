// The wire between the simulator's rendered room cameras and `vision_station track --source sim:SOCKET`:
// a Unix stream socket at SOCKET (the simulator listens, the station connects). Native byte order, both
// ends on one host. Documented in docs/vision_station.md ("Ground cameras in the simulator's loop").
//
//   simulator -> station, per frame set:  SetHeader, then `cameras` images of width*height*3 bytes (BGR)
//   station -> simulator, per frame set, after its fixes for that set have been written to the radio
//   ports:                                SetAnswer, then `vehicles` VehicleReport
// Each frame carries its own capture time: equal when the cameras are triggered together, spread by
// their phases when they run free. The simulator closing the socket ends the station's source.
#pragma once

#include <cstdint>

namespace quad::vision::ground_sim_protocol {

inline constexpr uint32_t kSetMagic = 0x51534746;     // "QSGF"
inline constexpr uint32_t kAnswerMagic = 0x51534741;  // "QSGA"
inline constexpr uint32_t kMaxCameras = 8;
inline constexpr int kColours = 4;                    // red, green, blue, yellow

struct SetHeader {
  uint32_t magic = kSetMagic;
  uint32_t cameras = 0;
  uint32_t width = 0, height = 0;
  uint64_t sequence = 0;                          // counts frame sets from 0 (lost sets leave gaps)
  int64_t capture_time_us[kMaxCameras] = {};      // per camera, simulated time = the vehicles' HIL clock
};

struct SetAnswer {
  uint32_t magic = kAnswerMagic;
  uint32_t vehicles = 0;          // VehicleReport records that follow
  uint64_t sequence = 0;          // the set answered
  uint64_t fixes_sent = 0;        // fix frames written to the radio ports so far (all sets, all vehicles)
  double processing_us = 0.0;     // the station's wall-clock time for this set (tracking, output)
  double cpu_us = 0.0;            // the same work's CPU time on the station's thread
  int64_t fix_time_us = 0;        // the time the fixes of this set carry (the mean capture time)
};

struct VehicleReport {
  int32_t id = 0;
  uint32_t found = 0;             // 1 when the set gave this vehicle a pose
  double ned[3] = {};             // the pose's position (body origin), metres
  float pixels[kColours][kMaxCameras][2] = {};  // associated detection per colour and camera (NaN: none)
  int32_t ambiguous_gates = 0;    // this set's gate groups shared with another track or detection
  int32_t epipolar_resolutions = 0;  // ... of those, settled with the epipolar constraint
};

static_assert(sizeof(SetHeader) == 88 && sizeof(SetAnswer) == 48 && sizeof(VehicleReport) == 296,
              "fixed wire layout");

}  // namespace quad::vision::ground_sim_protocol
