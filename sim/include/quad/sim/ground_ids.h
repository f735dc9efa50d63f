// A fleet vehicle's system id at the ground side of its UDP port. Every firmware is system 1 on its own
// link (quad/link/dialect.h); a ground station that sees several vehicles needs each under its own id
// (the scenario's vehicles[i].system_id). The simulator translates at the ground side:
//   - to the ground: the vehicle's frames leave as system_id (header rewritten, CRC recomputed);
//   - to the vehicle: a message addressed to system_id is readdressed to 1 (re-encoded); one addressed
//     to 0 (everyone) passes as it is; one addressed to another system is not this vehicle's and is dropped.
// Signed frames pass unchanged both ways: their signature covers the header and the payload.
#pragma once

#include <cstddef>
#include <cstdint>

#include "quad/link/mavlink.h"

namespace quad::sim {

struct GroundIdStats {
  uint64_t restamped = 0, readdressed = 0, dropped = 0, signed_passed = 0;
};

class GroundIds {
 public:
  explicit GroundIds(uint8_t system_id) : id_(system_id) {}
  // The frame as the ground station gets it; returns its size in out (0 when out is too small).
  size_t to_ground(const mavlink::Frame& f, uint8_t* out, size_t capacity);
  // The frame as the vehicle gets it; 0 when it is for another system (or out is too small).
  size_t to_vehicle(const mavlink::Frame& f, uint8_t* out, size_t capacity);
  uint8_t system_id() const { return id_; }
  const GroundIdStats& stats() const { return stats_; }

 private:
  uint8_t id_;
  GroundIdStats stats_;
};

}  // namespace quad::sim
