// The firmware's flight modes as the simulator names them: numbers and names are the link dialect's
// (quad/link/dialect.h), the same list the firmware is built from.
#pragma once

#include <string>

#include "quad/link/dialect.h"

namespace quad::sim {

constexpr int kFlightModeCount = mavlink::kFlightModeCount;

inline std::string flight_mode_name(int mode) {
  if (mode < 0 || mode >= kFlightModeCount) return "?";
  return mavlink::flight_mode_name(static_cast<mavlink::FlightMode>(mode));
}

}  // namespace quad::sim
