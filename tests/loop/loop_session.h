// The session every loop test flies: the built quad_firmware and `vision_station run`, without the
// progress line. Needs QUAD_SIM_FIRMWARE and QUAD_VISION_STATION, which tests/loop/CMakeLists.txt defines.
#pragma once

#include <string>

#include "quad/sim/hil_session.h"

namespace quad::sim {

inline SessionOptions loop_session_options(const std::string& out_dir) {
  SessionOptions o;
  o.out_dir = out_dir;
  o.firmware_argv = {QUAD_SIM_FIRMWARE};
  o.station_argv = {QUAD_VISION_STATION, "run"};
  o.progress = false;
  return o;
}

}  // namespace quad::sim
