// The firmware's flight modes (quad/firmware/modes.h) as the simulator names them: numbers and names are
// the firmware's own, never copied. On the host, the firmware's flash texts are ordinary memory.
#pragma once

#include <string>

#include "quad/firmware/modes.h"

namespace quad::sim {

constexpr int kFlightModeCount = static_cast<int>(fw::FlightMode::kLanding) + 1;

inline std::string flight_mode_name(int mode) {
  if (mode < 0 || mode >= kFlightModeCount) return "?";
  return fw::mode_name(static_cast<fw::FlightMode>(mode)).p;
}

}  // namespace quad::sim
